"""Options of the identification pipeline, loadable from config/identification.yaml.

The YAML keys are the option names below (the CLI's ``--r-sigma`` is ``r_sigma``). A file may be a
plain mapping or a ROS 2 parameter file (``<node or /**>: ros__parameters: {...}``).

The options come in five groups by concern, read as ``opts.<group>.<name>``: ``input`` (how the
records are read), ``observe`` (filtering, time base, reversals, decimation), ``solve``
(weighting, methods, model columns, essential parameters, excitation checks, partial answers),
``live`` (live identification) and ``consistency`` (physical consistency). A name belongs to one
group and stays the user's flat key: the YAML key, the ROS parameter and the CLI flag.
"""
from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.yaml_files import load_yaml

log = logging.getLogger("orthoglide_ident.identify")

DEFAULT_FILTER_CUTOFF_HZ = 100.0  # the derivative filter's cut-off from 500 Hz up
RATE_TO_FILTER = 5.0  # below 500 Hz, f_m / 5 (0.4 of the Nyquist frequency)
DECIMATION_TO_FILTER = 0.4  # decimation cut-off / derivative filter cut-off (40 / 100 Hz)
DEFAULT_BRIDGE_S = 0.02  # longest velocity-reversal run bridged (s), from 150 Hz up
MIN_BRIDGE_SAMPLES = 3  # below: that many samples
MIN_PAYLOAD_SHARE = 0.01  # fraction of a joint's rms torque the payload must add (partial.py;
# the design applies it too: excite/design.py)
DEPRECATED = {"decimation": "decimation_cutoff_hz (Hz)", "chunk_samples": "chunk_s (s)"}

# keys of config/identification.yaml that are the node's or a request's, not pipeline options
NODE_KEYS = ("method", "essential", "payload_mass", "gains", "bags", "robot", "joint_states_topic",
             "dynamic_joint_states_topic", "current_reference_topic")


@dataclass
class ExcitationLimits:
    """Thresholds of :func:`tls.check_excitation` (configurable in config/identification.yaml)."""

    max_condition: float = 1.0e7  # of the column-scaled regressor W
    max_singular_ratio: float = 0.5  # s_c / s_(c-1) of W_tot
    max_gain_rel_std: float = 0.05  # fraction
    # plausible drive gains per joint (N/A or N·m/A): (lowest, highest) arrays or numbers;
    # None: no band (no nominal gains given); outside it a warning, an error when band_is_error
    gain_range: tuple | None = (200.0, 20000.0)
    band_is_error: bool = False


@dataclass(frozen=True)
class InputOptions:
    """How the records are read: the current's timing and unit, the velocity's source, bad
    samples, the payload known."""

    # how a record's current relates to its stamps (observe/sampling.py): "held" over the step
    # that follows (a controller at the log rate: the states at the step's middle), "sampled" at
    # the stamp from a faster loop (the states at the stamp), "auto": a bag's tag
    # orthoglide.current_sampling, else the robot file's key, else held unless the identified
    # current-loop lag comes out negative (impossible: then sampled). A tag wins over this
    current_sampling: str = "auto"
    # Hz, the rate of the faster loop a sampled record's current comes from (a 1 kHz
    # controller): the states at t_k + 1 / (2 x this), the middle of that loop's own hold;
    # 0: unknown, the states at the stamp
    current_loop_hz: float = 0.0
    # the joint velocity: "derived" from q (band-pass derivative filter); "recorded": the bag's
    # JointState.velocity (low-passed like q); "auto": recorded when every sample has a finite
    # one that agrees with the derivative of q within velocity_agreement (rms, relative, each
    # joint), else derived. The choice is logged and in the diagnostics.
    velocity_source: str = "derived"
    velocity_agreement: float = 0.02
    nonfinite: str = "error"  # NaN/inf in the data: "error" or "drop" (treated as gaps)
    # The current of a ros2_control robot: the DynamicJointState interface read first when a
    # bag (or the live topics) has /dynamic_joint_states; "" = "current"
    current_interface: str = ""
    # what the current source holds: "A", a current (the drive's reference or measurement), or
    # "torque", a torque / force (N·m or N, e.g. JointState.effort without a current mapping),
    # turned into a current with the robot's nominal gains: the gains found are then the true
    # ones, and their ratio to the nominal ones the calibration of that torque. A bag tagged
    # orthoglide.effort_unit (an imported CSV log's) is read as its tag says, whatever this is
    effort_unit: str = "A"
    payload_mass_std_kg: float = 0.001  # std of the weighed payload mass (reported for m_7)
    payload_tolerance_kg: float = 0.0005  # bag tag vs --payload-mass disagreement allowed
    # what is known of the loaded bags' payload (paper Sect. 4.3): "" from each bag's tag
    # (orthoglide.payload_known, else what it gives: mass only, + CoM, + inertia), or for all of
    # them: mass | com | all | point (a point mass at the frame, or at the tagged CoM)
    payload_known: str = ""

    def validate(self, source: str = "options") -> None:
        if self.nonfinite not in ("error", "drop"):
            raise ConfigError(f"{source}: nonfinite must be 'error' or 'drop'")
        if self.current_sampling not in ("held", "sampled", "auto"):
            raise ConfigError(f"{source}: current_sampling must be held (over the step that "
                              "follows), sampled (at the stamp, from a faster loop) or auto")
        if not (self.current_loop_hz >= 0 and math.isfinite(self.current_loop_hz)):
            raise ConfigError(f"{source}: current_loop_hz is the faster loop's rate in Hz (0: "
                              f"unknown), not {self.current_loop_hz:g}")
        if self.velocity_source not in ("derived", "recorded", "auto"):
            raise ConfigError(f"{source}: velocity_source must be derived, recorded or auto")
        if not self.velocity_agreement > 0:
            raise ConfigError(f"{source}: velocity_agreement must be > 0 (a fraction)")
        if self.effort_unit not in ("A", "torque"):
            raise ConfigError(
                f"{source}: effort_unit must be 'A' (a current) or 'torque' (N·m or N)"
            )
        if self.payload_known not in ("", "mass", "com", "all", "point"):
            raise ConfigError(f"{source}: payload_known must be mass, com, all or point (or "
                              f"empty: from the bags' tags), not {self.payload_known!r}")


@dataclass(frozen=True)
class ObserveOptions:
    """The observation matrix's making: filtering, time base, velocity reversals, decimation."""

    # Every length is in s and every cut-off in Hz, so that the answer does not change with the
    # sample rate (at_rate turns them into samples for one record). 0 = from the record's rate.
    # Butterworth low-pass of q before differentiation, Hz: well above the dynamics (Sect. 3.2)
    # and above the decimation cut-off so that W keeps the whole band Y keeps; 0: min(100 Hz,
    # f_m / 5) (100 Hz from 500 Hz up; 18 Hz for a 91 Hz record)
    filter_cutoff_hz: float = 0.0
    filter_order: int = 4
    zoh_shift: bool = True  # evaluate the model at t_k + T/2 (zero-order hold of v_tau)
    # v_tau low-passed by the same zero-phase Butterworth as q (parallel filtering: W and v_tau see
    # one filter up to the decimation's 40 Hz, where the Butterworth already takes 0.07 %): the
    # 20-40 Hz content of a closed loop otherwise biases a gain by ~0.05 % (bench/identify_accuracy)
    filter_currents: bool = True
    edge_trim_s: float = 0.25  # dropped at both ends of each segment (filter transients)
    # cut-off of the parallel decimation (eqs. 19-20), Hz: n_d = round(0.8 f_m / (2 f_d)), the
    # paper's ω_fp = 2π 0.8 f_m / (2 n_d) matched to the derivative filter; 0: 0.4 x its cut-off
    # (40 Hz: n_d = 10 at 1 kHz, 50 at 5 kHz, 5 at 91 Hz)
    decimation_cutoff_hz: float = 0.0
    decimation_filter: str = "fir"  # zero-phase "fir" (fast, exact in chunks) or "cheby1" (MATLAB)
    # where W is built (stream.py, fir only): "rows", a robot model that names its rough columns
    # (the general one: sign(q̇) friction; the lag and ripple columns) has its other, smooth
    # columns built at the decimated rows only, from the states through the same decimation
    # filter, the rough ones and v_tau filtered at the sample rate (eqs. 19-20); "samples":
    # every column at every sample, then decimated (the Orthoglide's closed form always)
    regressor_at: str = "rows"
    chunk_s: float = 16.384  # s, W is built and decimated in chunks of this length (memory)
    # Old names, in samples (their answer changed with the rate): obeyed for one release with a
    # note when non-zero; at_rate sets them from the options above for one record
    decimation: int = 0  # n_d; use decimation_cutoff_hz
    chunk_samples: int = 0  # use chunk_s
    # Velocity reversals (reversals.py): samples of joint j with |q̂̇_j| below the dead band are
    # bridged by a straight line of the joint-j equation; longer runs are left out. 0: off.
    velocity_deadband_mps: float = 0.02
    # s; 0: max(20 ms, 3 samples): at a low rate a run left out costs every decimated row whose
    # (3.2 / f_d s long) window it touches, so a few samples are bridged rather than left out
    reversal_max_bridge_s: float = 0.0
    reversal_margin_s: float = 0.008  # bridges widened by this on both sides (filter smear)

    def at_rate(self, rate_hz: float) -> ObserveOptions:
        """These options for a record of mean sample rate ``rate_hz``: the cut-offs filled in
        (0 = from the rate), ``decimation`` (n_d) and ``chunk_samples`` set from
        ``decimation_cutoff_hz`` and ``chunk_s`` unless the old names were given."""
        f_q = self.filter_cutoff_hz or min(DEFAULT_FILTER_CUTOFF_HZ, rate_hz / RATE_TO_FILTER)
        n_d = self.decimation
        if n_d <= 0:
            f_d = self.decimation_cutoff_hz or DECIMATION_TO_FILTER * f_q
            n_d = max(1, int(round(0.8 * rate_hz / (2.0 * f_d))))
        chunk = self.chunk_samples or max(64, int(round(self.chunk_s * rate_hz)))
        bridge = self.reversal_max_bridge_s or max(DEFAULT_BRIDGE_S, MIN_BRIDGE_SAMPLES / rate_hz)
        return dataclasses.replace(self, filter_cutoff_hz=f_q, decimation=n_d,
                                   reversal_max_bridge_s=bridge,
                                   decimation_cutoff_hz=0.8 * rate_hz / (2.0 * n_d),
                                   chunk_samples=chunk)

    def describe_rates(self) -> str:
        """One line of the cut-offs of options resolved by :meth:`at_rate`."""
        return (f"derivative filter {self.filter_cutoff_hz:.4g} Hz, decimation by "
                f"{self.decimation} (cut-off {self.decimation_cutoff_hz:.4g} Hz)")

    def min_segment_samples(self, period_s: float = 1e-3) -> int:
        """Shortest segment worth keeping: both trims plus a few decimated samples."""
        trim = int(round(self.edge_trim_s / period_s))
        return 2 * trim + 16 * self.decimation + 32

    def validate(self, source: str = "options") -> None:
        if self.decimation_filter not in ("fir", "cheby1"):
            raise ConfigError(f"{source}: decimation_filter must be 'fir' or 'cheby1'")
        if self.regressor_at not in ("rows", "samples"):
            raise ConfigError(f"{source}: regressor_at must be 'rows' (W's smooth columns at the "
                              "decimated rows) or 'samples' (every column at every sample)")
        if self.decimation < 0 or self.filter_order < 1 or not (
                self.chunk_samples == 0 or self.chunk_samples >= 64):
            raise ConfigError(f"{source}: decimation >= 0 (0: from decimation_cutoff_hz), "
                              "filter_order >= 1 and chunk_samples 0 or >= 64")
        if not (self.chunk_s > 0 and self.decimation_cutoff_hz >= 0):
            raise ConfigError(f"{source}: chunk_s must be > 0 s and decimation_cutoff_hz >= 0 Hz "
                              "(0: from the derivative filter's cut-off)")
        if self.filter_cutoff_hz < 0:
            raise ConfigError(f"{source}: filter_cutoff_hz must be > 0 Hz, or 0: from the rate")


@dataclass(frozen=True)
class SolveOptions:
    """The solution: weighting, TLS's noisy columns and cross-check, the model's extra columns,
    essential parameters, excitation checks, partial answers and the gains' plausible band."""

    weighting: bool = True  # per-joint row weighting (Sect. 4.2 / eq. 28)
    # "all": the paper's TLS (every column of W_tot noisy); "currents": mixed LS-TLS, W and W_kl
    # exact, only the current references noisy (the sim's and the robot's case): same answer when
    # the trajectories excite well, and no near-null regressor direction mistaken for the gains
    # when they excite less; "per-joint" (default): the mixed LS-TLS with each current column
    # scaled to its joint's noise, without which TLS biases small gains when the joints' current
    # noise differs (issue 43, docs/guide/iv.md)
    tls_noisy_columns: str = "per-joint"
    # after TLS, IDIM-IV from its answer: a gain further than 3 combined σ from IV's is warned
    # about and not determined (docs/guide/iv.md); "none": no cross-check
    cross_check: str = "iv"
    r_sigma: float = 10.0  # essential parameters stop at max %σ / min %σ < r_sigma
    # "keep_gains": cancel by the r_sigma order only while the gains (TLS) or the estimated
    # payload masses (WLS) stay within max(their σ, essential_min_tolerance) of the base model's
    # and the residual grows by at most essential_max_residual_increase; "paper": Sect. 5.2 as is
    # a position-periodic force found in the residual (a screw's friction ripple at its lead):
    # "auto" adds two columns per joint that has one (drive_terms.py), "off" leaves it to the σ
    ripple_model: str = "auto"
    # m, the ball screws' lead (a datasheet value) when known: each joint then gets the friction
    # ripple's two columns at that period, built at the sample rate and decimated with W
    # (columns/layout.py); 0: unknown, left to ripple_model
    screw_lead_m: float = 0.0
    # each joint's current-loop lag (the drive applies g_τ (v_τ - τ v̇_τ)): "auto" adds a column
    # per joint when every segment repeats a periodic trajectory, its instrument the mean of v̇_τ
    # over the other periods (current_lag.py; live over the previous ones, each segment's first
    # ~4 periods held until its period is known); "off": the paper's model
    lag_model: str = "auto"
    essential_method: str = "keep_gains"
    essential_min_tolerance: float = 0.003  # fraction (0.3 %)
    essential_max_residual_increase: float = 0.05  # fraction of the weighted residual norm
    check_excitation: bool = True
    max_condition: float = 1.0e7  # error above; a warning above warn_condition
    warn_condition: float = 1.0e5
    max_singular_ratio: float = 0.5
    max_gain_rel_std: float = 0.05
    # partial answers (identify/partial.py): a gain the data do not fix (its joint hardly moved,
    # the payload adds less than min_payload_share of its torque, its honest σ above
    # max_gain_rel_std) is reported "not determined" with the reason, the others identified
    # without its rows; false: all or nothing (an error, as before)
    partial_answers: bool = True
    min_payload_share: float = MIN_PAYLOAD_SHARE
    # drive gains outside [nominal / ratio, nominal x ratio] of the robot file's nominal
    # (manufacturer's) gains are a warning (no band when the file gives none: a bare URDF);
    # gain_min / gain_max > 0 set absolute bounds instead, an error (N/A, N·m/A)
    gain_range_ratio: float = 10.0
    gain_min: float = 0.0
    gain_max: float = 0.0

    def limits(self, nominal_gains: Sequence[float], given: bool = True) -> ExcitationLimits:
        """The excitation checks' thresholds for a robot of these nominal gains (N/A, N·m/A).

        The band around the nominal gains (a warning) exists only when the robot file gives
        them (``given``); gain_min / gain_max > 0 are the user's own bounds (an error)."""
        g = np.asarray(nominal_gains, float)
        absolute = self.gain_min > 0 or self.gain_max > 0
        band = None
        if given or absolute:
            lo = np.full_like(g, self.gain_min) if self.gain_min > 0 else (
                g / self.gain_range_ratio if given else np.zeros_like(g))
            hi = np.full_like(g, self.gain_max) if self.gain_max > 0 else (
                g * self.gain_range_ratio if given else np.full_like(g, np.inf))
            band = (lo, hi)
        return ExcitationLimits(self.max_condition, self.max_singular_ratio,
                                self.max_gain_rel_std, band, band_is_error=absolute)

    def validate(self, source: str = "options") -> None:
        if self.cross_check not in ("iv", "none"):
            raise ConfigError(f"{source}: cross_check must be 'iv' or 'none'")
        if self.tls_noisy_columns not in ("all", "currents", "per-joint"):
            raise ConfigError(f"{source}: tls_noisy_columns must be 'all', 'currents' or "
                              "'per-joint'")
        if self.r_sigma <= 1:
            raise ConfigError(f"{source}: r_sigma must be > 1 (the paper uses 10)")
        if self.ripple_model not in ("auto", "off"):
            raise ConfigError(f"{source}: ripple_model must be 'auto' or 'off'")
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
        if not 0 <= self.min_payload_share < 1:
            raise ConfigError(f"{source}: min_payload_share is a fraction of a joint's torque "
                              f"(0.01 = 1 %), not {self.min_payload_share:g}")


@dataclass(frozen=True)
class LiveOptions:
    """Live identification (identify/live/) and its warnings while recording."""

    live_block_s: float = 1.0  # new paired data processed in blocks of about this length
    live_pairing_slack_s: float = 0.02  # a tick is paired once both topics are this far past it
    live_still_s: float = 2.0  # warn when a joint stays below the velocity dead band this long
    live_enough_gain_rel_std: float = 0.005  # status "enough data" once every gain's σ is below
    current_limit_a: float = 0.0  # A, the drives' current limit; 0: no saturation warning
    current_warn_fraction: float = 0.9  # warn when |v_tau| reaches this fraction of the limit

    def validate(self, source: str = "options") -> None:
        if not (self.live_block_s > 0 and self.live_pairing_slack_s >= 0
                and self.live_still_s > 0 and self.current_limit_a >= 0
                and 0 < self.current_warn_fraction <= 1):
            raise ConfigError(f"{source}: live_block_s, live_still_s > 0, live_pairing_slack_s, "
                              "current_limit_a >= 0 and 0 < current_warn_fraction <= 1")


@dataclass(frozen=True)
class ConsistencyOptions:
    """Physical consistency (consistency/): standard parameters whose pseudo-inertias are PSD
    (and ia, fv, fs >= 0) behind the answer, projected and identified under the constraints."""

    consistent: bool = False
    consistency_prior_weight: float = 1.0e-4  # weight of the prior, in the unknowns' scales
    # JSON of prior standard parameters (CAD values): {name: value, ...} for some or all, or an
    # identify --json output with a consistency section; "": the robot description's / weak default
    consistency_prior: str = ""

    def validate(self, source: str = "options") -> None:
        if not (self.consistency_prior_weight > 0 and math.isfinite(self.consistency_prior_weight)):
            raise ConfigError(f"{source}: consistency_prior_weight must be a positive number "
                              "(1e-4: the prior decides only what the data leave free)")


# the groups, in the order of config/identification.yaml: attribute of IdentifyOptions -> class;
# frozen, since the options replace() makes share the groups it leaves alone
GROUPS: dict[str, type] = {"input": InputOptions, "observe": ObserveOptions,
                           "solve": SolveOptions, "live": LiveOptions,
                           "consistency": ConsistencyOptions}


def _key_groups() -> dict[str, str]:
    """Each flat key (a YAML key, a ROS parameter, an attribute of one group) -> its group."""
    table: dict[str, str] = {}
    for group, cls in GROUPS.items():
        for f in fields(cls):
            if f.name in table:
                raise TypeError(f"option {f.name} is in both {table[f.name]} and {group}")
            table[f.name] = group
    return table


KEY_GROUP = _key_groups()


@dataclass
class IdentifyOptions:
    """Tuning of the pipeline, by concern (see the module's docstring); units in the names (Hz,
    s, m/s, kg, N/A). A joint-space unit names the Orthoglide's prismatic one: for a revolute
    joint read rad for m (e.g. ``velocity_deadband_mps`` is rad/s there) and N·m/A for N/A."""

    input: InputOptions = field(default_factory=InputOptions)
    observe: ObserveOptions = field(default_factory=ObserveOptions)
    solve: SolveOptions = field(default_factory=SolveOptions)
    live: LiveOptions = field(default_factory=LiveOptions)
    consistency: ConsistencyOptions = field(default_factory=ConsistencyOptions)

    @classmethod
    def of(cls, **flat: Any) -> IdentifyOptions:
        """The defaults with these flat keys changed (``IdentifyOptions.of(r_sigma=5.0)``); not
        validated, as a dataclass's constructor."""
        return cls().replace(**flat)

    @staticmethod
    def flat_fields() -> Iterator[tuple[str, Any, str]]:
        """(flat key, default, group) of every option, group by group (the node's parameters)."""
        for group, cls in GROUPS.items():
            base = cls()
            for f in fields(cls):
                yield f.name, getattr(base, f.name), group

    def flat(self) -> dict[str, Any]:
        """Every option by its flat key (the JSON diagnostics' ``options``)."""
        return {k: getattr(getattr(self, g), k) for k, g in KEY_GROUP.items()}

    def replace(self, **changes: Any) -> IdentifyOptions:
        """These options with flat keys changed, each in its group (None values ignored)."""
        by_group: dict[str, dict[str, Any]] = {}
        for k, v in changes.items():
            if k not in KEY_GROUP:
                raise TypeError(f"IdentifyOptions has no option {k!r}")
            if v is not None:
                by_group.setdefault(KEY_GROUP[k], {})[k] = v
        return dataclasses.replace(self, **{g: dataclasses.replace(getattr(self, g), **c)
                                            for g, c in by_group.items()})

    def at_rate(self, rate_hz: float) -> IdentifyOptions:
        """These options for a record of mean sample rate ``rate_hz`` (ObserveOptions.at_rate)."""
        return dataclasses.replace(self, observe=self.observe.at_rate(rate_hz))

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any], source: str = "options") -> IdentifyOptions:
        """Options from a mapping of flat keys; unknown keys and wrong types raise
        :class:`ConfigError`."""
        defaults = {k: d for k, d, _ in cls.flat_fields()}
        out: dict[str, Any] = {}
        for key, value in data.items():
            k = str(key).replace("-", "_")
            if k not in defaults:
                if k in NODE_KEYS:
                    continue  # request keys and node parameters in the same YAML file
                raise ConfigError(f"{source}: unknown option {key!r}; known: "
                                  f"{', '.join(defaults)}")
            out[k] = _coerce(key, value, defaults[k], source)
        opts = cls.of(**out)
        opts.validate(source)
        for old, new in DEPRECATED.items():
            if old in out and out[old]:
                log.warning("%s: option %s is in samples (deprecated, its answer changes with the "
                            "sample rate): use %s; obeyed for this release", source, old, new)
        return opts

    def validate(self, source: str = "options") -> None:
        for group in GROUPS:
            getattr(self, group).validate(source)

    @classmethod
    def from_yaml(cls, path: str | Path) -> IdentifyOptions:
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


def _coerce(key: Any, value: Any, default: Any, source: str) -> Any:
    """``value`` as the type of the option's ``default`` (ConfigError naming the key if not)."""
    try:
        if isinstance(default, bool):
            if not isinstance(value, bool):
                raise TypeError
            return value
        if isinstance(default, int):
            return int(value)
        if isinstance(default, float):
            return float(value)
        if isinstance(value, bool):  # YAML's bare on/off: the words meant
            return "on" if value else "off"
        return str(value)
    except (TypeError, ValueError):
        raise ConfigError(f"{source}: option {key} = {value!r} should be "
                          f"{type(default).__name__}") from None
