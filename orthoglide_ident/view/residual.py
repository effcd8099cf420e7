"""The live residual: measured force g_τ v_τ against the identified model's, per joint.

    τ_meas[k] = g_τ ⊙ v̂_τ[k]                                            eq. (17)
    τ_model[k] = W(q̂, q̂̇, q̂̈)(t_k + T/2) χ_b + W_kl m_7                  eq. (29)

with g_τ and χ_b the latched identified parameters and m_7 the payload the recorder says is on.
The states come from the positions themselves, by the identification's own band-pass derivative
filter (identify/filtering.py: zero-phase Butterworth, central differences, half a tick later for
the zero-order hold) and v_τ through the same low-pass, so that the residual is the one the
identification minimises. Not from the setpoints' q̇_d, q̈_d: those are the reference, not the
motion (the tracking error's dynamics would show as a model error), and a robot controller need
not publish them. The zero-phase filter needs ``filter_horizon`` ticks (0.16 s at 1 kHz) after a
row: the residual runs that far behind the newest tick. Only consecutive ticks are filtered
together; a gap (lost ticks) restarts the filter.

Rows are averaged over blocks of ``block_s`` (the view's period, 20 ms: 20 ticks at 1 kHz): one
value per joint a browser can plot at 50 Hz, with the noise of 20 ticks averaged away. Joints are
those of the robot model, in
its order; the messages may carry them in any order, with others beside them.

A robot with a transmission (model/transmission.py) is identified in actuator space, and so is
its residual: the positions and currents arrive on the channels of their side (joint-side
positions under the joints' names, currents under the motors'), are mapped to the motors on
arrival as the live identification maps them (q_m = N q_j + offset, v_m = N⁻ᵀ v_j), and the
forces are each motor's, g_a v_a against motor a's row (N⁻ᵀ W χ_b plus its own ia, fv, fs); the
joints' residual Nᵀ (τ_meas − τ_model) comes beside them (``ForceBlock.joint_residual``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from orthoglide_ident.errors import ConfigError
from orthoglide_ident.identify.live.recording import channel_maps
from orthoglide_ident.identify.observe.filtering import (
    filter_horizon,
    filtered_states,
    zero_phase_butterworth,
)
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.model.robot import RobotModel

MAX_PENDING = 5000  # unpaired ticks kept per topic (5 s at 1 kHz): one topic may lag the other


@dataclass
class ForceBlock:
    """Means over one block of ticks: stamp (ns, the block's middle tick), forces (n_joints,):
    the motors' for a robot with a transmission, whose joints' residual is ``joint_residual``
    (Nᵀ (measured − model), None without a transmission)."""

    stamp_ns: int
    measured: np.ndarray
    model: np.ndarray
    ticks: int
    joint_residual: np.ndarray | None = None


class ForceResidual:
    """Pairs joint positions and current references by stamp and gives ``ForceBlock``s."""

    def __init__(
        self, model: RobotModel, block_s: float = 0.02, options: IdentifyOptions | None = None
    ) -> None:
        opts = options or IdentifyOptions()
        # ticks per block, once the period is known
        self.model, self.block_s, self.block = model, float(block_s), 1
        self.transmission = model.transmission
        # the channels q and v arrive on, and their map to the model's (a transmission's motors)
        self.channels = dict(
            zip(("q", "v"), channel_maps(tuple(model.joint_names), self.transmission))
        )
        self.opts = opts  # cut-offs resolved at the record's rate (IdentifyOptions.at_rate)
        self.cutoff_hz, self.order = opts.observe.filter_cutoff_hz, opts.observe.filter_order
        self.zoh_shift, self.filter_currents = opts.observe.zoh_shift, opts.observe.filter_currents
        self.g_tau: np.ndarray | None = None  # (n,) in the model's joint order
        self.chi: np.ndarray | None = None  # (n_b,)
        self.payload_mass = 0.0
        self.pending: dict[str, dict[int, np.ndarray]] = {"q": {}, "v": {}}
        self.period_ns: int | None = None
        self.horizon = 0
        self._restart()

    def _restart(self) -> None:
        n = self.model.n_joints
        self.t = np.empty(0, np.int64)
        self.q = np.empty((0, n))
        self.v = np.empty((0, n))
        self.done = None  # first row of the buffer not yet output (None: segment just started)

    # ---- inputs --------------------------------------------------------------------------------
    def set_parameters(self, joint_names: list[str], drive_gains: list[float], names: list[str],
                       values: list[float]) -> None:
        """The identified parameters (orthoglide_msgs/IdentifiedParameters fields); parameters the
        message lacks (cancelled as non-essential) count as 0. ConfigError when they are not of
        this robot's base model."""
        index = {n: i for i, n in enumerate(self.model.names)}
        unknown = [n for n in names if n not in index]
        if unknown or len(names) != len(values):
            raise ConfigError(
                f"identified parameters are not those of robot {self.model.name}'s base model "
                f"(unknown: {', '.join(unknown[:4]) or 'none'}; {len(names)} names, "
                f"{len(values)} values): no model force"
            )
        gains = dict(zip(joint_names, drive_gains))
        missing = [j for j in self.model.joint_names if j not in gains]
        if missing:
            raise ConfigError(f"identified parameters lack the drive gains of {', '.join(missing)}")
        chi = np.zeros(self.model.n_b)
        chi[[index[n] for n in names]] = np.asarray(values, float)
        self.chi = chi
        self.g_tau = np.array([gains[j] for j in self.model.joint_names], float)

    def set_payload(self, mass_kg: float) -> None:
        """The payload on the robot now (kg; 0 unloaded): its force is part of the model's."""
        self.payload_mass = float(mass_kg)

    def add(
        self, topic: str, stamps_ns: np.ndarray, names: tuple[str, ...], values: np.ndarray
    ) -> None:
        """Decoded ticks of ``topic`` "q" (positions) or "v" (current references), values (m,
        len(names))."""
        wanted, to_model = self.channels[topic]
        missing = [j for j in wanted if j not in names]
        if missing:
            raise ConfigError(
                f"{'positions' if topic == 'q' else 'currents'} lack joints {', '.join(missing)} "
                f"of robot {self.model.name} (have {', '.join(names)})"
            )
        values = np.asarray(values, float)[:, [names.index(j) for j in wanted]]
        if to_model is not None:  # a transmission's joint-side channels, to its motors
            values = to_model(values)
        pend = self.pending[topic]
        pend.update(zip(np.asarray(stamps_ns).tolist(), values))
        if len(pend) > MAX_PENDING:
            for s in sorted(pend)[:len(pend) - MAX_PENDING]:
                del pend[s]

    # ---- output --------------------------------------------------------------------------------
    def take(self) -> list[ForceBlock]:
        """The blocks whose ticks and filter context have all arrived, oldest first."""
        self._pair()
        if self.period_ns is None or self.done is None:
            return []
        H, B = self.horizon, self.block
        k = (len(self.t) - H - 1 - self.done) // B  # whole blocks with H ticks of context after
        if k <= 0:
            return []
        if self.g_tau is None:  # no model yet: these ticks are passed, only their context kept
            self.done += k * B
            self._trim()
            return []
        a, b = self.done - H, self.done + k * B + H + 1
        try:
            return self._blocks(self.t[a:b], self.q[a:b], self.v[a:b], k)
        finally:  # even when the model refuses these states (ModelError): passed, not retried
            self.done += k * B
            self._trim()

    def _pair(self) -> None:
        """Move ticks present on both topics into the buffer, in stamp order; a gap restarts it."""
        pq, pv = self.pending["q"], self.pending["v"]
        both = sorted(pq.keys() & pv.keys())
        if not both:
            return
        stamps = np.array(both, np.int64)
        q = np.array([pq.pop(s) for s in both])
        v = np.array([pv.pop(s) for s in both])
        for pend in (pq, pv):  # ticks older than the newest pair will never be paired
            for s in [s for s in pend if s < both[-1]]:
                del pend[s]
        if self.period_ns is None:
            self._set_period(np.diff(np.concatenate([self.t, stamps])))
        if self.period_ns is None:
            self.t = np.concatenate([self.t, stamps])  # too few ticks yet to know the period
            self.q, self.v = np.concatenate([self.q, q]), np.concatenate([self.v, v])
            return
        # late ticks: too late
        keep = stamps > (self.t[-1] if len(self.t) else np.iinfo(np.int64).min)
        self._extend(stamps[keep], q[keep], v[keep])

    def _set_period(self, diffs: np.ndarray) -> None:
        if diffs.size >= 10 and np.median(diffs) > 0:
            self.period_ns = int(np.median(diffs))
            self.cutoff_hz = self.opts.at_rate(1e9 / self.period_ns).observe.filter_cutoff_hz
            self.horizon = filter_horizon(self.period_ns * 1e-9, self.cutoff_hz, self.order)
            self.block = max(1, round(self.block_s * 1e9 / self.period_ns))
            t, q, v = self.t, self.q, self.v
            self._restart()
            self._extend(t, q, v)

    def _extend(self, t: np.ndarray, q: np.ndarray, v: np.ndarray) -> None:
        """Append ticks; each gap (more than 1.5 periods) starts a new segment."""
        if t.size == 0:
            return
        prev = self.t[-1:] if len(self.t) else t[:1]
        gaps = np.flatnonzero(np.diff(np.concatenate([prev, t])) > 1.5 * self.period_ns)
        start = int(gaps[-1]) if gaps.size else 0  # the last segment is the one that goes on
        if gaps.size:
            self._restart()
        self.t = np.concatenate([self.t, t[start:]])
        self.q = np.concatenate([self.q, q[start:]])
        self.v = np.concatenate([self.v, v[start:]])
        if self.done is None and len(self.t) > self.horizon:
            self.done = self.horizon  # the first H ticks of a segment are context only

    def _trim(self) -> None:
        drop = self.done - self.horizon
        if drop > 0:
            self.t, self.q, self.v = self.t[drop:], self.q[drop:], self.v[drop:]
            self.done -= drop

    def _blocks(self, t: np.ndarray, q: np.ndarray, v: np.ndarray, k: int) -> list[ForceBlock]:
        """Forces of rows H .. H + k B of the window (t, q, v), averaged per block of B."""
        H, B, T = self.horizon, self.block, self.period_ns * 1e-9
        qf, qd, qdd = filtered_states(q, T, self.cutoff_hz, self.order, self.zoh_shift)
        if self.filter_currents:
            v = zero_phase_butterworth(v, T, self.cutoff_hz, self.order)
        rows = slice(H, H + k * B)
        qf, qd, qdd, v = qf[rows], qd[rows], qdd[rows], v[rows]
        n, m = self.model.n_joints, k * B
        tau_model = (self.model.regressor(qf, qd, qdd) @ self.chi).reshape(n, m).T
        if self.payload_mass:
            tau_model += (
                self.payload_mass * self.model.payload_mass_column(qf, qd, qdd).reshape(n, m).T
            )
        tau_meas = v * self.g_tau
        means = [a.reshape(k, B, n).mean(axis=1) for a in (tau_meas, tau_model)]
        mid = t[rows].reshape(k, B)[:, B // 2]
        tr = self.transmission
        joint = [None] * k if tr is None else tr.to_joint_effort(means[0] - means[1])
        return [ForceBlock(int(s), me, mo, B, j) for s, me, mo, j in zip(mid, *means, joint)]
