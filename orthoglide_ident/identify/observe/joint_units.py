"""A robot identified in actuator space solved in joint-side units (issue 33).

Motor a's equation (model/actuator_space.py) balances torques at the motor shaft. A motor on one
joint (a SimpleTransmission, N_aa = n) has a joint-side description too, the robot without a
transmission: joint a's equation is motor a's times n, its gain |n| g_a (the current flips with
n), its friction n² fv_a, |n| fs_a, its rotor inertia n² ia_a, its offset n off_a. The two are the
same equations in other units, yet neither solve is indifferent to units:

- IDIM-WLS (eq. 28) and IDIM-TLS (Sect. 4.2) weigh joint j's rows by 1/σ_j, σ_j from a first,
  unweighted pass; that first pass is a least-squares fit whose answer moves when one joint's rows
  are scaled against the others' (measured: 3e-6 on the UR5's residuals, 3e-4 on a weak base
  parameter, 0.01 σ).
- IDIM-TLS (eqs. 34-36) minimises ‖ΔW_tot‖_F, every column's error counted alike: the smallest
  right singular vector of W_tot C is not C⁻¹ times that of W_tot for a diagonal column scaling C
  (it is only for C = c·I). Expressing a gain per motor rather than per joint scales its column
  by 1/|n|: measured, 1e-4 on the gains (1.3 σ), 2.9 σ on a base parameter.

So the solvers take the equations in joint-side units: motor a's rows times s_a = max_j |N_aj|
in the first pass (:func:`equation_scale`), and for TLS the motor's own unknowns in joint-side
units (:func:`column_scale`: g_a s_a, ia_a s_a², fv_a s_a², fs_a s_a, off_a s_a, a lag or ripple
like the gain), reported back in motor units. With a diagonal N this is exactly the joint-side
description (same rows up to their signs, which neither solve sees: the answers agree to
round-off); with a coupling, s_a is the motor's largest reduction, the scale its friction and
dead band (reversals.velocity_deadband) are seen at. A robot without a transmission: None, the
paper's solve unchanged.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from orthoglide_ident.model.robot import DRIVE_KINDS

# power of s_a that turns a motor's own unknown into its joint-side value (module docstring)
POWERS = {"ia": 2, "fv": 2, "fs": 1, "tauoff": 1, "lag": 1, "ripple_c": 1, "ripple_s": 1}
assert set(DRIVE_KINDS) <= set(POWERS)


def transmission_scale(model) -> np.ndarray | None:
    """s_a = max_j |N_aj| for each of ``model``'s equations (its "joints", the motors), or None
    without a transmission. ``model``: the robot, or a partial answer's subsystem
    (solve/partial.Subsystem: the motors it keeps); both say it as ``motor_scale``."""
    return model.motor_scale


def equation_scale(model) -> np.ndarray | None:
    """Row scale of the solvers' first pass: s_a per equation (None: all ones, the paper's)."""
    return transmission_scale(model)


def column_scale(model, n_cols: int, names: Sequence[str] | None = None) -> np.ndarray | None:
    """(n_cols + n_j + 1,) C with W_tot C in joint-side units: over the ``n_cols`` columns of W
    (``names``, default ``model.names``; then any the solver appended, left as they are), the
    gains and the payload column (1). A column named ``<kind>_<actuator>`` (POWERS) gets
    1/s_a^power, a gain 1/s_a. None without a transmission."""
    s = transmission_scale(model)
    if s is None:
        return None
    names = list(model.names if names is None else names)[:n_cols]
    joints = list(model.joint_names)
    c = np.ones(n_cols + len(joints) + 1)
    for k, name in enumerate(names):
        for kind, power in POWERS.items():
            a = name[len(kind) + 1:] if name.startswith(kind + "_") else None
            if a in joints:
                c[k] = s[joints.index(a)] ** -power
                break
    c[n_cols:n_cols + len(joints)] = 1.0 / s
    return c
