"""Design of the exciting trajectories (paper Sect. 3.2) for the identification itself.

One Fourier shape (trajectory.py: L harmonics per joint, at rest at every whole period by
``rest_projection``) serves both runs; each run scales it by its own amplitude α (the loaded run
may need less to keep the motors' torque limits with the payload). Per joint the shape is scaled
so that its excursion from the start pose, its speed and its acceleration reach the joint's
limits less their margins (all three are linear in the amplitude: met by construction); the
efforts (nominal model with the payload), the distances between bodies and a closed chain's
working mode are penalties of the criterion, and the check (check.py) verifies them all again
on a 1 ms grid before anything is written.

Criterion (minimised): J = log max_j σ(g_j)/g_j + COND_WEIGHT · log κ, with σ the predicted
standard deviation of the gains (prediction.py: eq. 39 at the nominal model, both runs) — what
the user wants from the records — and κ the condition number of the column-scaled weighted
[W | V_τ], so that every base parameter stays excited too (the TLS needs W_tot's smallest
singular value set apart from the next one: a badly conditioned rest would let a near-null
regressor direction pass for the gains).

Search: the best of ``restarts`` random shapes (each made feasible by lowering its α), then
``steps`` of a seeded (1+1) evolution strategy (a Gaussian step kept when J drops; step ×1.5
on success, ×0.9 on failure), which copes with the kinks of the scaling and the penalties.
Repeatable for a seed on one machine; ``time_limit_s`` keeps the best so far. With ``search``
"gradient" (the default) the walk takes no steps unless asked, and its best shape is polished by
SLSQP with analytic gradients (gradient.py), then checked and repaired on the 1 ms grid alike.

The condition cap (``max_condition``, prediction.MAX_CONDITION) judges the design, not the
path: during the search only the directions null up to rounding (prediction.STRUCTURAL) are
left out, and a candidate beyond the cap pays OVER_CAP_WEIGHT · log(κ / cap) on top of J, so
the search climbs towards it. The final design's directions still beyond the cap are named
with their cause (the description's own dependence, tested on random motion free of the
limits; the motion's limits; a gain the payload does not scale) and left out of its
prediction; it is refused only when no gain is determined. A gain the payload adds less than
``min_payload_share`` of its torque to on the loaded run is refused by the identification
(identify/solve/partial.py): the design names it too and leaves it out of J (the search, a fixed
set: those free random motion does not load; the final design, its own loaded run). A refusal
names the constraint the best candidate breaks, with its value. A start pose nobody chose is
moved out of collision (``clear_start``).
"""
from __future__ import annotations

import dataclasses
import logging
import math
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from orthoglide_ident.errors import ConfigError, ExcitationError, ModelError
from orthoglide_ident.excite import prediction
from orthoglide_ident.excite.check import CheckReport, check_trajectory, nominal_efforts
from orthoglide_ident.excite.constraints import (
    Margins,
    Slack,
    TreeStates,
    collision_slack,
    joint_slacks,
    payload_dict,
)
from orthoglide_ident.excite.limits import JointLimits, excitation_section, home_pose
from orthoglide_ident.excite.prediction import (
    RATE_HZ,
    STRUCTURAL,
    Prediction,
    RunSamples,
    excitation_ratio,
    from_information,
    information,
    loaded_share,
    nominal_base_values,
    not_loaded_text,
    periodic_rate,
    run_rows,
    unloaded,
)
from orthoglide_ident.excite.trajectory import ExcitationRun, ExcitationTrajectory, rest_projection
from orthoglide_ident.identify.columns.current_lag import MIN_PERIODS
from orthoglide_ident.identify.options import DEFAULT_FILTER_CUTOFF_HZ, MIN_PAYLOAD_SHARE
from orthoglide_ident.identify.solve.partial import payload_too_small
from orthoglide_ident.model.robot import Payload
from orthoglide_ident.progress import ProgressLine, duration_text

_log = logging.getLogger("orthoglide_ident")

COND_WEIGHT = 0.25
OVER_CAP_WEIGHT = 1.0  # criterion per unit of log(κ / cap) beyond the cap (the search climbs)
SEARCH_CAP = 1.0 / math.sqrt(STRUCTURAL)  # κ of the directions the search leaves out
FREE_SAMPLES, FREE_SEED = 400, 12345  # random samples telling the description's dependences
# λ/λmax on those samples below which a direction is the description's own (κ > 1e4 on any
# motion; the xarm7's ia_2 + zz_2R, apart by its URDF's rounded angles: 3e-12, a 2-link arm's
# gravity terms on a 0.01 s period: 0.1)
FREE_DEPENDENT = 1e-8
PENALTY = 100.0  # criterion per unit of normalised violation (a feasible shape always wins)
VIOLATION_SCALE = {"position": 0.05, "velocity": 0.1, "acceleration": 0.1, "effort": 0.1,
                   "collision": 0.02, "working_mode": 0.05, "rate_growth": 0.1, "at_rest": 1.0}
SCALE_GRID = 500  # samples per period the linear limits are met on
ALPHA_START = 0.95  # a random shape's first amplitude, lowered by ALPHA_SHRINK until feasible
ALPHA_SHRINK = 0.75
REPAIR_SHRINK = 0.97  # amplitude factor per failed 1 ms check
REPAIRS = 15
EVALS_PER_START = 3  # evaluations of a random start, its amplitude cuts included (measured)
CHECK_EVALS = 20  # one 1 ms check and the final prediction, in evaluations
COLLISION_EVERY = 4  # the search's distances on every 4th sample: meshes cost ~30 ms a pose
BOUND_FACTOR = 1.0  # pairs whose bounding spheres are a margin apart: their bound is enough
CLEAR_FACTOR, CLEAR_TRIES = 1.5, 200  # a start pose nobody chose clears 1.5 margins
SEARCHES = ("walk", "gradient")  # the random walk alone; then polished with gradients
POLISH_STARTS = 1  # the walk's best (with 0 steps: the best random shape) polished
# (gradient.py); a 2nd start, the next random shape, gains 0.06 on the UR5 for twice the time
# random-walk steps by default: the polish climbs further from the best random shapes than
# from the walk's end (UR5: −5.83 after 400 steps, −6.22 after none)
STEPS = {"walk": 400, "gradient": 0}
# an SLSQP iteration in walk evaluations (its regressor partials, distance gradients, line
# search; measured: UR5 ~10, Panda ~33)
POLISH_EVALS_PER_ITER = 20


@dataclass(frozen=True)
class DesignOptions:
    """What to design: the payload the user will mount, period, number of periods, harmonics,
    the search's size and seed, the margins, the current noise (A per joint) of the prediction
    and its target σ of the gains (fraction)."""

    payload: Payload
    noise_a: np.ndarray
    period_s: float = 5.0
    periods: int = 12
    harmonics: int = 5
    seed: int = 0
    restarts: int = 20
    steps: int | None = None  # None: STEPS[search]
    samples: int = 100  # per period, for the criterion and the penalties
    margins: Margins = field(default_factory=Margins)
    target: float = 0.002
    pose: dict[str, float] | None = None
    max_condition: float | None = None  # κ beyond which a direction is not excited
    # (None: prediction.MAX_CONDITION)
    time_limit_s: float | None = None  # the search returns its best so far after this
    search: str = "gradient"  # SEARCHES (docs/benchmarks.md: better σ and κ on every arm)
    # a gain the payload adds less than this share of its torque to is not excited (the
    # identification's rule: SolveOptions.min_payload_share)
    min_payload_share: float = MIN_PAYLOAD_SHARE


    def __post_init__(self) -> None:
        if self.max_condition is None:
            object.__setattr__(self, "max_condition", prediction.MAX_CONDITION)
        if self.search not in SEARCHES:
            raise ConfigError(f"--search must be one of {', '.join(SEARCHES)}, not "
                              f"{self.search!r}")
        if self.steps is None:
            object.__setattr__(self, "steps", STEPS[self.search])
        if self.time_limit_s is not None and not self.time_limit_s > 0:
            raise ConfigError(f"--time-limit must be a positive number of seconds, not "
                              f"{self.time_limit_s:g}")
        if not (self.period_s > 0 and self.periods >= 1 and self.harmonics >= 1
                and self.restarts >= 1 and self.steps >= 0 and self.samples >= 10):
            raise ConfigError("period must be > 0 s, periods and harmonics >= 1, restarts >= 1, "
                              "steps >= 0, samples >= 10")
        if not self.payload.mass > 0:
            raise ConfigError(f"the loaded run needs a payload mass > 0 kg (--payload-mass), "
                              f"not {self.payload.mass:g}")
        noise = np.asarray(self.noise_a, float)
        if noise.ndim != 1 or not (np.all(np.isfinite(noise)) and np.all(noise > 0)):
            raise ConfigError(f"the current noise must be positive amperes per joint, not {noise}")
        if not (0 < self.target < 1):
            raise ConfigError(f"target σ must be a fraction in (0, 1), not {self.target:g}")


@dataclass
class Evaluation:
    criterion: float  # J without penalty (inf: the model cannot follow it)
    violation: float  # normalised, 0 when feasible
    prediction: Prediction | None
    worst: Slack | None = None  # the constraint furthest beyond its margin (None: none is)
    reason: str = ""  # why the model cannot follow it

    @property
    def score(self) -> float:
        return self.criterion + PENALTY * self.violation


def _logit(a: float) -> float:
    return math.log(a / (1.0 - a))


class Problem:
    """The search space (a shape and two amplitudes) and its criterion (module docstring)."""

    def __init__(self, robot, limits: JointLimits, collision, options: DesignOptions):
        self.robot, self.limits, self.collision, self.opt = robot, limits, collision, options
        self.n, self.L = robot.n_joints, options.harmonics
        self.w_f = 2.0 * math.pi / options.period_s
        self.P = home_pose(robot, limits, options.pose)
        self.kinds = [j.kind for j in robot.joints]
        m = options.margins
        pm = m.position_of(self.kinds)
        # the bounds met by construction: the joints' own, narrowed by their mimic joints'
        self.bounds = limits.through_mimics(pm, {x.joint: m.position_of([x.kind])[0]
                                                 for x in limits.mimics})
        self.lo, self.hi = self.bounds.lower, self.bounds.upper
        if np.any(self.P < self.lo) | np.any(self.P > self.hi):
            k = int(np.argmax((self.P < self.lo) | (self.P > self.hi)))
            followers = [x.joint for x in limits.mimics if x.leader == k]
            raise ConfigError(f"start pose of {robot.joint_names[k]} ({self.P[k]:g}) is within "
                              f"{pm[k]:g} of its limits" + (f" or puts its mimic joints "
                                                            f"{', '.join(followers)} there"
                                                            if followers else "")
                              + ": choose another (--pose)")
        self.t_scale = np.linspace(0.0, options.period_s, SCALE_GRID, endpoint=False)
        self.t = np.linspace(0.0, options.period_s, options.samples, endpoint=False)
        self.chi_b, self.gains = nominal_base_values(robot), robot.nominal_gains
        self.tree = TreeStates(robot)
        self.runs = (("unloaded", None), ("loaded", options.payload))
        self.ell = np.arange(1, self.L + 1, dtype=float)
        self.evals = 0  # evaluations so far (the expected duration)
        self.starts: list[tuple[float, np.ndarray]] = []  # feasible random shapes (score, x)
        try:  # the gains the search leaves out (loaded_gains): a share told, below the rule
            share = self.free_payload_share()
            self.unloadable = np.isfinite(share) & payload_too_small(share,
                                                                     options.min_payload_share)
        except ModelError:  # a closed chain that does not assemble at random poses: none
            self.unloadable = np.zeros(self.n, bool)

    @property
    def size(self) -> int:
        return 2 * self.n * self.L + 2

    def shape(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(a, b) of shape ``x`` at rest at the period's ends, scaled per joint to the limits."""
        nl = self.n * self.L
        a, b = rest_projection(x[:nl].reshape(self.n, self.L), x[nl:2 * nl].reshape(self.n, self.L))
        kw = self.w_f * self.ell
        s, c = np.sin(np.outer(self.t_scale, kw)), np.cos(np.outer(self.t_scale, kw))
        d = s @ (a / kw).T - (c - 1.0) @ (b / kw).T  # q(t) - q(0)
        qd, qdd = c @ a.T + s @ b.T, -s @ (a * kw).T + c @ (b * kw).T
        with np.errstate(divide="ignore", invalid="ignore"):
            room = np.where(d > 0, (self.hi - self.P) / d, np.where(d < 0, (self.lo - self.P) / d,
                                                                    np.inf))
            m = self.opt.margins
            lim = self.bounds
            scale = np.min([room.min(axis=0),
                            lim.velocity * (1 - m.velocity) / np.abs(qd).max(axis=0),
                            lim.acceleration * (1 - m.acceleration) / np.abs(qdd).max(axis=0)],
                           axis=0)
        scale = np.where(np.isfinite(scale), scale, 0.0)
        return a * scale[:, None], b * scale[:, None]

    def trajectory(self, x: np.ndarray) -> ExcitationTrajectory:
        a, b = self.shape(x)
        runs = {}
        for k, (name, payload) in enumerate(self.runs):
            alpha = 1.0 / (1.0 + math.exp(-x[-2 + k]))
            A, B = a * alpha, b * alpha
            q0 = self.P + (B / (self.w_f * self.ell)).sum(axis=1)  # q(0) = P
            runs[name] = ExcitationRun(name, q0, A, B, payload_dict(payload))
        return ExcitationTrajectory(self.robot.name, self.robot.joint_names, self.opt.period_s,
                                    self.opt.periods, runs)

    def evaluate(self, x: np.ndarray) -> Evaluation:
        return self.evaluate_trajectory(self.trajectory(x))

    def evaluate_trajectory(self, traj: ExcitationTrajectory) -> Evaluation:
        self.evals += 1
        F, violation, worst = 0.0, 0.0, None
        for name, payload in self.runs:
            q, qd, qdd = traj.evaluate(name, self.t)
            try:
                X, tau = rows = run_rows(self.robot, self.chi_b, self.gains,
                                         RunSamples(q, qd, qdd, traj.duration, payload))
                slacks = self.slacks(q, qd, qdd, tau.T, name)
            except ModelError as exc:
                return Evaluation(math.inf, math.inf, None, reason=f"{name} run: {exc}")
            for s in slacks:
                v = max(0.0, s.required - s.value) / VIOLATION_SCALE[s.kind]
                violation += v
                if v > 0 and (worst is None or v > worst[0]):
                    worst = (v, s)
            F = F + information(X, tau, self.gains, self.opt.noise_a,
                                RATE_HZ * traj.duration / len(self.t), self.lag_rate(tau))
        # the search sees every direction but those null up to rounding (prediction.STRUCTURAL)
        # and designs for the gains the payload scales (the loaded run's rows: the last)
        pred = self.loaded_gains(self.predict(F, SEARCH_CAP), rows, search=True)
        return Evaluation(self.criterion(pred), violation, pred,
                          None if worst is None else worst[1])

    def predict(self, F: np.ndarray, cap: float) -> Prediction:
        names = list(self.robot.names) + [f"g({j})" for j in self.robot.joint_names]
        return from_information(F, self.chi_b, self.gains, self.opt.noise_a, cap, names)

    def loaded_gains(self, pred: Prediction, loaded: tuple[np.ndarray, np.ndarray],
                     payload: Payload | None = None, search: bool = False) -> Prediction:
        """``pred`` without the gains the payload does not scale on the ``loaded`` run's rows
        (X, τ) by the identification's rule (prediction.loaded_share); ``search``: those no
        motion lets it scale instead (``unloadable``), a fixed set: no shape gains by unloading
        a joint whose σ is the worst."""
        share = loaded_share(*loaded, (payload or self.opt.payload).mass)
        low = self.unloadable if search else payload_too_small(share, self.opt.min_payload_share)
        return unloaded(pred, share, low, self.robot.joint_names)

    def free_payload_share(self) -> np.ndarray:
        """The loaded run's payload share on free random motion (free_motion_information's
        samples): what any motion lets the payload add (0 on an axis through a point mass)."""
        q, qd, qdd = self.free_samples(np.random.default_rng(FREE_SEED))
        return loaded_share(*run_rows(self.robot, self.chi_b, self.gains,
                                      RunSamples(q, qd, qdd, 1.0, self.opt.payload)),
                            self.opt.payload.mass)

    def criterion(self, pred: Prediction) -> float:
        """J (module docstring) of the gains and directions the motion can reach; beyond the
        cap, ranked by κ so that the search climbs towards it (the cap judges the answer)."""
        kappa = pred.condition_kept
        crit = math.log(pred.worst_determined_gain()) + COND_WEIGHT * math.log(kappa) + \
            OVER_CAP_WEIGHT * max(0.0, math.log(kappa / self.opt.max_condition))
        return crit if math.isfinite(crit) else math.inf

    def final_prediction(self, x: np.ndarray) -> Prediction:
        return self.prediction_of(self.trajectory(x))

    def prediction_of(self, traj: ExcitationTrajectory) -> Prediction:
        """The design's prediction, the cap (``max_condition``) judging which directions it
        excites."""
        F = 0.0
        for name, payload in self.runs:
            q, qd, qdd = traj.evaluate(name, self.t)
            X, tau = rows = run_rows(self.robot, self.chi_b, self.gains,
                                     RunSamples(q, qd, qdd, traj.duration, payload))
            F = F + information(X, tau, self.gains, self.opt.noise_a,
                                RATE_HZ * traj.duration / len(self.t), self.lag_rate(tau))
        pred = self.loaded_gains(self.predict(F, self.opt.max_condition), rows)
        if not pred.unexcited:
            return pred
        try:
            G = self.free_motion_information()
        except ModelError:  # a closed chain that does not assemble at random poses: not told
            return pred
        return dataclasses.replace(pred, unexcited=tuple(
            dataclasses.replace(u, on_any_motion=bool(excitation_ratio(G, u.direction)
                                                      < FREE_DEPENDENT))
            for u in pred.unexcited))

    def free_motion_information(self) -> np.ndarray:
        """F of random samples free of the limits' coupling (uniform positions in range,
        speeds and accelerations up to the limits, both runs): what the description allows
        on any motion, to tell a dependence of the description from one of the motion."""
        rng = np.random.default_rng(FREE_SEED)
        q, qd, qdd = self.free_samples(rng)
        F = 0.0
        for _, payload in self.runs:
            X, tau = run_rows(self.robot, self.chi_b, self.gains,
                              RunSamples(q, qd, qdd, 1.0, payload))
            # the lag columns (when the design has them) get independent random rates
            rate = None if self.opt.periods < MIN_PERIODS else rng.normal(size=tau.shape) * \
                np.abs(tau).mean(axis=1, keepdims=True) * self.w_f
            F = F + information(X, tau, self.gains, self.opt.noise_a, 1.0, rate)
        return F

    def free_samples(self, rng: np.random.Generator):
        """FREE_SAMPLES random (q, q̇, q̈): positions in range, rates up to the limits."""
        m = FREE_SAMPLES
        q = rng.uniform(self.limits.lower, self.limits.upper, (m, self.n))
        qd = self.limits.velocity * rng.uniform(-1, 1, (m, self.n))
        qdd = self.limits.acceleration * rng.uniform(-1, 1, (m, self.n))
        return q, qd, qdd

    def lag_rate(self, tau: np.ndarray) -> np.ndarray | None:
        """τ̇ for the current-loop lag terms the identification adds on periodic records
        (prediction.py), when the runs repeat often enough for it (current_lag.MIN_PERIODS)."""
        if self.opt.periods < MIN_PERIODS:
            return None
        return periodic_rate(tau, self.opt.period_s / len(self.t))

    def slacks(self, q, qd, qdd, tau, run: str) -> list[Slack]:
        m = self.opt.margins
        out = joint_slacks(self.limits, self.kinds, m, q, qd, qdd, tau, self.t, run)
        if (self.collision is not None and self.collision.mode != "skip") or \
                self.tree.closure is not None:
            Q, G = self.tree.configurations(q)
            k = COLLISION_EVERY  # the 1 ms check (and its repair) sees every sample
            out += collision_slack(self.collision, Q[::k], m, self.t[::k], run,
                                   bound=BOUND_FACTOR * m.collision)
            out += self.tree.mode_slacks(Q, G, m, self.t, run)
        return out

    def with_alpha(self, x: np.ndarray, k: int, factor: float) -> np.ndarray:
        """``x`` with run k's amplitude times ``factor``."""
        y = x.copy()
        alpha = 1.0 / (1.0 + math.exp(-y[-2 + k]))
        y[-2 + k] = _logit(min(max(alpha * factor, 1e-6), 1 - 1e-9))
        return y


@dataclass
class Design:
    """A designed trajectory, its 1 ms check, its prediction, and the search's figures."""

    trajectory: ExcitationTrajectory
    check: CheckReport
    prediction: Prediction
    criterion: float
    random: list[Evaluation]  # the random shapes made feasible (bench: median of these)
    seconds: float
    problem: Problem


def static_payload_check(robot, limits: JointLimits, margins: Margins, P: np.ndarray,
                         payload: Payload) -> None:
    """ConfigError when holding the payload at rest at the start pose already needs more than
    the effort limits allow (less their margin): no trajectory can carry it."""
    z = np.zeros((1, robot.n_joints))
    tau = nominal_efforts(robot, payload, P[None], z, z)[0]
    allowed = limits.effort * (1 - margins.effort)
    over = np.abs(tau) > allowed
    if over.any():
        j = int(np.argmax(np.abs(tau) / allowed))
        raise ConfigError(f"a {payload.mass:g} kg payload needs {abs(tau[j]):.4g} "
                          f"{robot.joints[j].effort_unit} on {robot.joint_names[j]} at rest at the "
                          f"start pose, above {allowed[j]:.4g} (its effort limit "
                          f"{limits.effort[j]:g} less {100 * margins.effort:g} %): mount a "
                          "lighter payload")


def short_period(limits: JointLimits, options: DesignOptions) -> str:
    """The reason when the period, not the margins nor the payload, leaves too little motion:
    at the first harmonic ω₁ = 2π/T a joint's acceleration limit caps its velocity at
    q̈_max/ω₁; when that is below its velocity limit on every joint, a longer period allows
    more motion of each (up to T = 2π q̇_max/q̈_max, where the velocity limit binds). ""
    otherwise."""
    w1 = 2.0 * math.pi / options.period_s
    acc, vel = np.asarray(limits.acceleration, float), np.asarray(limits.velocity, float)
    ok = np.isfinite(acc) & np.isfinite(vel) & (acc > 0)
    if not ok.any() or np.any(acc[ok] / w1 >= vel[ok]):
        return ""
    longest = float(np.max(2.0 * math.pi * vel[ok] / acc[ok]))
    return (f"the period {options.period_s:g} s is too short: at its first harmonic "
            f"({1 / options.period_s:.3g} Hz) the acceleration limits cap every joint's motion at "
            f"±{float(np.max(acc[ok] / w1 ** 2)):.2g} (its velocity at "
            f"{float(np.max(acc[ok] / w1)):.2g}, against velocity limits of "
            f"{float(np.min(vel[ok])):.3g} and more; rad or m), too little to identify the "
            f"model; use --period {longest:.2g} s or longer (the acceleration limits then allow "
            "the velocity limits; default 5 s)")


def period_check(limits: JointLimits, options: DesignOptions) -> None:
    """Refuse a fundamental at or above half the identification's derivative-filter cut-off
    (identify/options.py, at 1 kHz): the identification would not see the motion, whatever the
    search finds; the reason names the period (short_period's closed form when it applies)."""
    f1 = 1.0 / options.period_s
    if f1 >= 0.5 * DEFAULT_FILTER_CUTOFF_HZ:
        raise ExcitationError(short_period(limits, options) or (
            f"the period {options.period_s:g} s puts the motion at {f1:.3g} Hz and above, where "
            f"the identification's derivative filter ({DEFAULT_FILTER_CUTOFF_HZ:g} Hz) takes it "
            "out: use a period of seconds (default 5 s)"))


def _random_start(problem: Problem, rng: np.random.Generator
                  ) -> tuple[np.ndarray, Evaluation, int]:
    """(x, its evaluation, the evaluations it took)."""
    x = np.concatenate([rng.normal(size=problem.size - 2), [_logit(ALPHA_START)] * 2])
    ev, n = problem.evaluate(x), 1
    for _ in range(10):
        if ev.violation == 0:
            break
        x = problem.with_alpha(problem.with_alpha(x, 0, ALPHA_SHRINK), 1, ALPHA_SHRINK)
        ev, n = problem.evaluate(x), n + 1
    return x, ev, n


class Clock:
    """The search's time: the limit (``time_limit_s``) and the expected duration from the
    first evaluations."""

    def __init__(self, limit: float | None):
        self.t0, self.limit = time.perf_counter(), limit

    @property
    def elapsed(self) -> float:
        return time.perf_counter() - self.t0

    def out(self) -> bool:
        return self.limit is not None and self.elapsed > self.limit


def expected_seconds(problem: Problem, per_eval: float) -> float:
    """The search's duration at ``per_eval`` s per evaluation: each random start's evaluations
    (1 + its amplitude cuts, ~3 on average), the steps, the gradient polish's iterations
    (~POLISH_EVALS_PER_ITER each), the 1 ms checks (~20 evaluations)."""
    from orthoglide_ident.excite.gradient import MAX_ITER

    opt = problem.opt
    polish = POLISH_STARTS * MAX_ITER * POLISH_EVALS_PER_ITER if opt.search == "gradient" else 0
    return per_eval * (EVALS_PER_START * opt.restarts + opt.steps + polish + CHECK_EVALS)


def search(problem: Problem, progress: Callable[[str], None] | None = None,
           clock: Clock | None = None, note: Callable[[str], None] | None = None
           ) -> tuple[np.ndarray, Evaluation, list[Evaluation]]:
    """The best x found (module docstring), its evaluation and the feasible random starts'
    (within ``clock``'s time limit: the best so far); ``progress`` while searching, ``note``
    the expected duration and the time limit (default: ``progress``)."""
    opt = problem.opt
    rng = np.random.default_rng(opt.seed)
    clock = clock or Clock(opt.time_limit_s)
    line = ProgressLine("designing", opt.restarts + opt.steps, "evaluations")  # a terminal's
    said, noted = progress or (lambda _: None), note or progress or (lambda _: None)

    def say(text: str) -> None:  # a message on a line of its own, the progress line after it
        line.close()
        said(text)

    def note(text: str) -> None:
        line.close()
        noted(text)

    best_x, best, randoms, evals = None, None, [], 0
    for r in range(opt.restarts):
        x, ev, n = _random_start(problem, rng)
        evals += n
        line.update(evals, evals / (r + 1) * opt.restarts + opt.steps)
        if ev.violation == 0 and math.isfinite(ev.criterion):
            randoms.append(ev)
            problem.starts.append((ev.score, x))
        if best is None or ev.score < best.score:
            best_x, best = x, ev
        if r == 0:
            note("expected duration ~"
                 + duration_text(expected_seconds(problem, clock.elapsed / problem.evals))
                 + f" ({opt.restarts} random shapes, {opt.steps} steps"
                 + (", then the gradient polish" if opt.search == "gradient" else "")
                 + (f", stopping at {opt.time_limit_s:g} s" if opt.time_limit_s else "") + ")")
        if clock.out():
            note(f"time limit {opt.time_limit_s:g} s: stopping after {r + 1} random shapes")
            return best_x, best, randoms
    say(f"best of {opt.restarts} random shapes: {_describe(best)} "
        f"({len(randoms)} feasible)")
    step, n_shape = 0.05, problem.size - 2
    for k in range(opt.steps):
        if clock.out():
            note(f"time limit {opt.time_limit_s:g} s: the best of {k} steps")
            break
        scale = np.concatenate([np.full(n_shape, np.abs(best_x[:n_shape]).mean()), [1.0, 1.0]])
        y = best_x + step * scale * rng.normal(size=best_x.size)
        ev = problem.evaluate(y)
        if ev.score < best.score:
            best_x, best, step = y, ev, step * 1.5
        else:
            step *= 0.9
        line.update(evals + k + 1)
        if (k + 1) % max(1, opt.steps // 8) == 0:
            say(f"step {k + 1}/{opt.steps} ({clock.elapsed:.0f} s): {_describe(best)}")
    line.close()
    return best_x, best, randoms


def _describe(ev: Evaluation) -> str:
    if ev.prediction is None:
        return ev.reason or "the model cannot follow any shape"
    p = ev.prediction
    return (f"worst gain σ {100 * p.worst_determined_gain():.3g} %, κ {p.condition_kept:.3g}"
            + ("" if ev.violation == 0 else f", {_slack_text(ev.worst)}"))


def _slack_text(s: Slack | None) -> str:
    if s is None:
        return "no constraint broken"
    return f"{s.kind} {s.value:.4g} < {s.required:.4g} at {s.where}"


def repaired(problem: Problem, x: np.ndarray, say: Callable[[str], None]
             ) -> tuple[np.ndarray, ExcitationTrajectory, CheckReport]:
    """x whose trajectory passes the 1 ms check, lowering the amplitude of a failing run."""
    for attempt in range(REPAIRS + 1):
        traj = problem.trajectory(x)
        report = check_trajectory(traj, problem.robot, problem.limits, problem.collision,
                                  problem.opt.margins)
        if report.ok:
            return x, traj, report
        if attempt == REPAIRS:
            break
        bad = {s.run for s in report.slacks if not s.ok}
        say(f"1 ms check: {', '.join(s.kind for s in report.failures())} short of the margin; "
            f"lowering the amplitude of the {' and '.join(sorted(bad))} run")
        for k, (name, _) in enumerate(problem.runs):
            if name in bad:
                x = problem.with_alpha(x, k, REPAIR_SHRINK)
    worst = "; ".join(_slack_text(s) for s in report.failures())
    raise ExcitationError(f"no trajectory within the limits was found ({worst}): "
                          + _remedy(report.failures()[0].kind))


REMEDIES = {"position": "a start pose further from the limits (--pose)",
            "velocity": "a longer period (--period) or looser velocity limits",
            "acceleration": "a longer period (--period) or looser acceleration limits",
            "effort": "a lighter payload, a longer period (--period) or another start pose",
            "collision": "another start pose (--pose) further from the bodies named",
            "working_mode": "another start pose (--pose) within the working mode",
            "rate_growth": "another start pose (--pose) further from the singularities",
            "at_rest": "more samples per period"}


def _remedy(kind: str) -> str:
    return f"{REMEDIES.get(kind, 'loosen the margins')} would help"


def _refusal(best: Evaluation) -> ExcitationError:
    """Why no feasible design was found: the constraint the best candidate breaks furthest
    (kind, value, margin, where), or why the model cannot follow it."""
    if best.prediction is None and best.worst is None:
        return ExcitationError(f"no shape can be followed: {best.reason or 'the model fails'}")
    return ExcitationError(f"no feasible trajectory found: even at a small amplitude the best "
                           f"shape breaks {_slack_text(best.worst)}; "
                           + _remedy(best.worst.kind if best.worst else ""))


def _clearance(problem: Problem, q: np.ndarray) -> float:
    Q, _ = problem.tree.configurations(q[None])
    return float(problem.collision.distances(Q).min(initial=math.inf))


def clear_start(problem: Problem, say: Callable[[str], None]) -> None:
    """A start pose nobody chose (no --pose, no excitation.home) at the middle of the ranges
    but within CLEAR_FACTOR × the collision margin of a body: moved to the nearest of seeded
    random poses, at growing distances within the ranges, that clears it (said)."""
    robot, col, m = problem.robot, problem.collision, problem.opt.margins
    section_home = "home" in excitation_section(robot)[0]
    if problem.opt.pose or section_home or col is None or col.mode == "skip" or \
            problem.tree.closure is not None:
        return
    need = CLEAR_FACTOR * m.collision
    d0 = _clearance(problem, problem.P)
    if d0 >= need:
        return
    rng = np.random.default_rng(problem.opt.seed)
    half = 0.5 * (problem.hi - problem.lo)
    for k in range(CLEAR_TRIES):
        radius = (k + 1) / CLEAR_TRIES
        q = np.clip(problem.P + radius * half * rng.uniform(-1, 1, problem.n), problem.lo,
                    problem.hi)
        d = _clearance(problem, q)
        if d >= need:
            say(f"start pose: the middle of the ranges is {d0:.3g} m from a body (margin "
                f"{m.collision:g} m); moved to {', '.join(f'{x:.3g}' for x in q)} ({d:.3g} m)")
            problem.P = q
            return
    raise ConfigError(f"the middle of the joint ranges is {d0:.3g} m from a body (margin "
                      f"{m.collision:g} m) and no pose near it clears it: give a start pose "
                      "(--pose or excitation.home)")


def design(robot, limits: JointLimits, collision, options: DesignOptions,
           progress: Callable[[str], None] | None = None) -> Design:
    """Design both runs for ``robot`` (module docstring); the 1 ms check passed. Directions
    beyond the cap are named (Prediction.unexcited) and the design is for the rest; refused
    (ExcitationError) when no gain is determined."""
    say = progress or _log.info
    steps = progress or (_log.info if sys.stderr.isatty() else None)  # on a terminal only
    clock = Clock(options.time_limit_s)
    problem = Problem(robot, limits, collision, options)
    clear_start(problem, say)
    period_check(limits, options)
    static_payload_check(robot, limits, options.margins, problem.P, options.payload)
    x, best, randoms = search(problem, steps, clock, say)
    if best.violation > 0 or best.prediction is None:
        raise _refusal(best)
    target = problem
    if options.search == "gradient" and not clock.out():
        target, x = polished(problem, x, best, say, clock)
    x, traj, report = repaired(target, x, say)
    pred = problem.prediction_of(traj)
    if pred.undetermined_gains.all():
        raise ExcitationError("no drive gain is determined by any motion within the limits: "
                              + "; ".join([u.to_text() for u in pred.unexcited]
                                          + [not_loaded_text(j) for j in pred.not_loaded]))
    for u in pred.unexcited:
        say(f"not excited: {u.to_text()}")
    for j in pred.not_loaded:
        say(f"not excited: {not_loaded_text(j)}")
    return Design(traj, report, pred, problem.criterion(pred), randoms, clock.elapsed, problem)


def polished(problem: Problem, x: np.ndarray, best: Evaluation, say: Callable[[str], None],
             clock: Clock | None = None):
    """(gradient.Polish, its v): the walk's best ``x`` and the best random shapes polished
    by SLSQP with analytic gradients (gradient.py), the gains ``best`` determines kept."""
    from orthoglide_ident.excite.gradient import distinct, polish

    ranked = [y for _, y in sorted(problem.starts, key=lambda s: s[0])]
    determined = np.isfinite(best.prediction.gain_rel_std)
    if not determined.any():  # nothing to climb: the refusal follows (design)
        return problem, x
    # a closed chain's working mode is checked on every sample (Problem.slacks)
    every = COLLISION_EVERY if problem.tree.closure is None else 1
    nlp, v, _ = polish(problem, distinct([x] + ranked)[:POLISH_STARTS], SEARCH_CAP,
                       COND_WEIGHT, determined, say, every, clock)
    return nlp, v


def payload_options(problem: Problem, traj: ExcitationTrajectory, masses: list[float]
                    ) -> list[tuple[float, Prediction | None]]:
    """The prediction with each payload mass on the loaded run's motion (None where the effort
    limits refuse it), the payload's CoM and inertia per kg kept."""
    p = problem.opt.payload
    out = []
    for m in masses:
        load = Payload(m, p.frame, p.com, tuple(x * m / p.mass for x in p.inertia))
        F, ok = 0.0, True
        for name, payload in (("unloaded", None), ("loaded", load)):
            q, qd, qdd = traj.evaluate(name, problem.t)
            X, tau = rows = run_rows(problem.robot, problem.chi_b, problem.gains,
                                     RunSamples(q, qd, qdd, traj.duration, payload))
            ok &= bool(np.all(np.abs(tau.T) <= problem.limits.effort *
                              (1 - problem.opt.margins.effort)))
            F = F + information(X, tau, problem.gains, problem.opt.noise_a,
                                RATE_HZ * traj.duration / len(problem.t), problem.lag_rate(tau))
        out.append((m, problem.loaded_gains(problem.predict(F, problem.opt.max_condition), rows,
                                            load) if ok else None))
    return out

