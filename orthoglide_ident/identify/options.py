"""Options of the identification pipeline, loadable from config/identification.yaml.

The YAML keys are the option names below (the CLI's ``--r-sigma`` is ``r_sigma``). A file may be a
plain mapping or a ROS 2 parameter file (``<node or /**>: ros__parameters: {...}``).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.yaml_files import load_yaml


# keys of config/identification.yaml that are the node's or a request's, not pipeline options
NODE_KEYS = ("method", "essential", "payload_mass", "gains", "bags", "robot", "joint_states_topic",
             "dynamic_joint_states_topic", "current_reference_topic")


@dataclass
class ExcitationLimits:
    """Thresholds of :func:`tls.check_excitation` (configurable in config/identification.yaml)."""

    max_condition: float = 1.0e7  # of the column-scaled regressor W
    max_singular_ratio: float = 0.5  # s_c / s_(c-1) of W_tot
    max_gain_rel_std: float = 0.05  # fraction
    # plausible drive gains per joint (N/A or N·m/A): (lowest, highest) arrays or numbers
    gain_range: tuple = (200.0, 20000.0)


@dataclass
class IdentifyOptions:
    """Tuning of the pipeline; units in the names (Hz, s, m/s, kg, N/A). A joint-space unit
    names the Orthoglide's prismatic one: for a revolute joint read rad for m (e.g.
    ``velocity_deadband_mps`` is rad/s there) and N·m/A for N/A."""

    # Butterworth low-pass of q before differentiation, Hz: well above the decimation cut-off
    # 0.8 f_m / (2 n_d) = 40 Hz so that W keeps the whole band Y keeps
    filter_cutoff_hz: float = 100.0
    filter_order: int = 4
    zoh_shift: bool = True  # evaluate the model at t_k + T/2 (zero-order hold of v_tau)
    # v_tau low-passed by the same zero-phase Butterworth as q (parallel filtering: W and v_tau see
    # one filter up to the decimation's 40 Hz, where the Butterworth already takes 0.07 %): the
    # 20-40 Hz content of a closed loop otherwise biases a gain by ~0.05 % (bench/identify_accuracy)
    filter_currents: bool = True
    edge_trim_s: float = 0.25  # dropped at both ends of each segment (filter transients)
    decimation: int = 10  # n_d of the parallel decimation (eqs. 19-20)
    decimation_filter: str = "fir"  # zero-phase "fir" (fast, exact in chunks) or "cheby1" (MATLAB)
    chunk_samples: int = 16384  # W is built and decimated in chunks of this many samples
    # Velocity reversals (reversals.py): samples of joint j with |q̂̇_j| below the dead band are
    # bridged by a straight line of the joint-j equation; longer runs are left out. 0: off.
    velocity_deadband_mps: float = 0.02
    reversal_max_bridge_s: float = 0.02
    reversal_margin_s: float = 0.008  # bridges widened by this on both sides (filter smear)
    nonfinite: str = "error"  # NaN/inf in the data: "error" or "drop" (treated as gaps)
    # The current of a ros2_control robot: the DynamicJointState interface read first when a
    # bag (or the live topics) has /dynamic_joint_states; "" = "current"
    current_interface: str = ""
    # what the current source holds: "A", a current (the drive's reference or measurement), or
    # "torque", a torque / force (N·m or N, e.g. JointState.effort without a current mapping),
    # turned into a current with the robot's nominal gains: the gains found are then the true
    # ones, and their ratio to the nominal ones the calibration of that torque
    effort_unit: str = "A"
    weighting: bool = True  # per-joint row weighting (Sect. 4.2 / eq. 28)
    # "all": the paper's TLS (every column of W_tot noisy); "currents": mixed LS-TLS, W and W_kl
    # exact, only the current references noisy (the sim's and the robot's case): same answer when
    # the trajectories excite well, and no near-null regressor direction mistaken for the gains
    # when they excite less
    tls_noisy_columns: str = "all"  # the paper's TLS (eqs. 35-36); "currents": mixed LS-TLS
    r_sigma: float = 10.0  # essential parameters stop at max %σ / min %σ < r_sigma
    # "keep_gains": cancel by the r_sigma order only while the gains (TLS) or the estimated
    # payload masses (WLS) stay within max(their σ, essential_min_tolerance) of the base model's
    # and the residual grows by at most essential_max_residual_increase; "paper": Sect. 5.2 as is
    # a position-periodic force found in the residual (a screw's friction ripple at its lead):
    # "auto" adds two columns per joint that has one (drive_terms.py), "off" leaves it to the σ
    ripple_model: str = "auto"
    # m, the ball screws' lead (a datasheet value) when known: each joint then gets the friction
    # ripple's two columns at that period, built at the sample rate and decimated with W
    # (drive_terms.DriveTermsModel); 0: unknown, left to ripple_model
    screw_lead_m: float = 0.0
    # each joint's current-loop lag (the drive applies g_τ (v_τ - τ v̇_τ)): "auto" adds a column
    # per joint when every segment repeats a periodic trajectory, its instrument the mean of v̇_τ
    # over the other periods (current_lag.py; live over the previous ones, each segment's first
    # ~4 periods held until its period is known); "off": the paper's model
    lag_model: str = "auto"
    essential_method: str = "keep_gains"
    essential_min_tolerance: float = 0.003  # fraction (0.3 %)
    essential_max_residual_increase: float = 0.05  # fraction of the weighted residual norm
    payload_mass_std_kg: float = 0.001  # std of the weighed payload mass (reported for m_7)
    payload_tolerance_kg: float = 0.0005  # bag tag vs --payload-mass disagreement allowed
    check_excitation: bool = True
    max_condition: float = 1.0e7  # error above; a warning above warn_condition
    warn_condition: float = 1.0e5
    max_singular_ratio: float = 0.5
    max_gain_rel_std: float = 0.05
    # plausible drive gains: within [nominal / ratio, nominal x ratio] of the robot's nominal
    # (manufacturer's) gains; gain_min / gain_max > 0 set absolute bounds instead (N/A, N·m/A)
    gain_range_ratio: float = 10.0
    gain_min: float = 0.0
    gain_max: float = 0.0
    # Live identification (identify/live.py)
    live_block_s: float = 1.0  # new paired data processed in blocks of about this length
    live_pairing_slack_s: float = 0.02  # a tick is paired once both topics are this far past it
    live_still_s: float = 2.0  # warn when a joint stays below the velocity dead band this long
    live_enough_gain_rel_std: float = 0.005  # status "enough data" once every gain's σ is below
    current_limit_a: float = 0.0  # A, the drives' current limit; 0: no saturation warning
    current_warn_fraction: float = 0.9  # warn when |v_tau| reaches this fraction of the limit
    # Physical consistency (consistency.py): standard parameters whose pseudo-inertias are PSD
    # (and ia, fv, fs >= 0) behind the answer, projected and identified under the constraints
    consistent: bool = False
    consistency_prior_weight: float = 1.0e-4  # weight of the prior, in the unknowns' scales
    # JSON of prior standard parameters (CAD values): {name: value, ...} for some or all, or an
    # identify --json output with a consistency section; "": the robot description's / weak default
    consistency_prior: str = ""

    def limits(self, nominal_gains: Sequence[float]) -> ExcitationLimits:
        """The excitation checks' thresholds for a robot of these nominal gains (N/A, N·m/A)."""
        g = np.asarray(nominal_gains, float)
        lo = np.full_like(g, self.gain_min) if self.gain_min > 0 else g / self.gain_range_ratio
        hi = np.full_like(g, self.gain_max) if self.gain_max > 0 else g * self.gain_range_ratio
        return ExcitationLimits(self.max_condition, self.max_singular_ratio,
                                self.max_gain_rel_std, (lo, hi))

    def min_segment_samples(self, period_s: float = 1e-3) -> int:
        """Shortest segment worth keeping: both trims plus a few decimated samples."""
        trim = int(round(self.edge_trim_s / period_s))
        return 2 * trim + 16 * self.decimation + 32

    def replace(self, **changes: Any) -> "IdentifyOptions":
        return dataclasses.replace(self, **{k: v for k, v in changes.items() if v is not None})

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any], source: str = "options") -> "IdentifyOptions":
        """Options from a mapping; unknown keys and wrong types raise :class:`ConfigError`."""
        known = {f.name: f for f in fields(cls)}
        base = cls()
        out: dict[str, Any] = {}
        for key, value in data.items():
            k = str(key).replace("-", "_")
            if k not in known:
                if k in NODE_KEYS:
                    continue  # request keys and node parameters in the same YAML file
                raise ConfigError(f"{source}: unknown option {key!r}; known: {', '.join(known)}")
            default = getattr(base, k)
            try:
                if isinstance(default, bool):
                    if not isinstance(value, bool):
                        raise TypeError
                    out[k] = value
                elif isinstance(default, int):
                    out[k] = int(value)
                elif isinstance(default, float):
                    out[k] = float(value)
                elif isinstance(value, bool):  # YAML's bare on/off: the words meant
                    out[k] = "on" if value else "off"
                else:
                    out[k] = str(value)
            except (TypeError, ValueError):
                raise ConfigError(f"{source}: option {key} = {value!r} should be "
                                  f"{type(default).__name__}") from None
        opts = cls(**out)
        opts.validate(source)
        return opts

    def validate(self, source: str = "options") -> None:
        if self.nonfinite not in ("error", "drop"):
            raise ConfigError(f"{source}: nonfinite must be 'error' or 'drop'")
        if self.tls_noisy_columns not in ("all", "currents"):
            raise ConfigError(f"{source}: tls_noisy_columns must be 'all' or 'currents'")
        if self.decimation_filter not in ("fir", "cheby1"):
            raise ConfigError(f"{source}: decimation_filter must be 'fir' or 'cheby1'")
        if self.decimation < 1 or self.filter_order < 1 or self.chunk_samples < 64:
            raise ConfigError(f"{source}: decimation, filter_order >= 1 and chunk_samples >= 64")
        if self.r_sigma <= 1:
            raise ConfigError(f"{source}: r_sigma must be > 1 (the paper uses 10)")
        if self.ripple_model not in ("auto", "off"):
            raise ConfigError(f"{source}: ripple_model must be 'auto' or 'off'")
        if self.effort_unit not in ("A", "torque"):
            raise ConfigError(f"{source}: effort_unit must be 'A' (a current) or 'torque' (N·m or N)")
        if self.lag_model not in ("auto", "off"):
            raise ConfigError(f"{source}: lag_model must be 'auto' or 'off'")
        if not (self.screw_lead_m == 0 or 1e-4 <= self.screw_lead_m <= 0.5):
            raise ConfigError(f"{source}: screw_lead_m is the screws' lead in metres (e.g. 0.010 "
                              f"for 10 mm), or 0 when unknown; not {self.screw_lead_m:g}")
        if self.essential_method not in ("keep_gains", "paper"):
            raise ConfigError(f"{source}: essential_method must be 'keep_gains' or 'paper'")
        if not (self.essential_min_tolerance >= 0 and self.essential_max_residual_increase >= 0):
            raise ConfigError(f"{source}: essential_min_tolerance and "
                              "essential_max_residual_increase must be >= 0 (fractions)")
        if not (self.gain_range_ratio > 1 and self.gain_min >= 0 and self.gain_max >= 0):
            raise ConfigError(f"{source}: gain_range_ratio must be > 1, gain_min and gain_max "
                              ">= 0 (0: from the nominal gains and the ratio)")
        if not (self.consistency_prior_weight > 0 and math.isfinite(self.consistency_prior_weight)):
            raise ConfigError(f"{source}: consistency_prior_weight must be a positive number "
                              "(1e-4: the prior decides only what the data leave free)")
        if self.filter_cutoff_hz <= 0:
            raise ConfigError(f"{source}: filter_cutoff_hz must be > 0")
        if not (self.live_block_s > 0 and self.live_pairing_slack_s >= 0
                and self.live_still_s > 0 and self.current_limit_a >= 0
                and 0 < self.current_warn_fraction <= 1):
            raise ConfigError(f"{source}: live_block_s, live_still_s > 0, live_pairing_slack_s, "
                              "current_limit_a >= 0 and 0 < current_warn_fraction <= 1")

    @classmethod
    def from_yaml(cls, path: str | Path) -> "IdentifyOptions":
        """Options from a YAML file: a plain mapping or a ROS 2 parameter file."""
        p = Path(path)
        data = load_yaml(p, "config")
        if data is None:
            return cls()
        if not isinstance(data, dict):
            raise ConfigError(f"config {p} must hold a mapping of options")
        # ROS 2 parameter file: {node: {ros__parameters: {...}}}
        for v in data.values():
            if isinstance(v, dict) and "ros__parameters" in v:
                data = v["ros__parameters"] or {}
                break
        return cls.from_mapping(data, str(p))
