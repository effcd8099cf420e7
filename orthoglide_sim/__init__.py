"""Orthoglide simulator: plant dynamics from an independent formulation, controllers, trajectories.

- ``true_parameters``: the plant's true standard parameters, drive gains, payloads (YAML overrides).
- ``kinematics``: the simulator's own geometry in jax (sphere intersection, MDH body poses).
- ``plant``: Lagrange's equations by automatic differentiation (inverse/forward dynamics, energy).
- ``simulator``: 10 kHz RK4 plant, 1 kHz controllers (pid, pid_ff, external) with zero-order hold,
  1 um encoder quantisation, current noise, optional screw ripple.
- ``trajectories`` / ``excitation``: the stored exciting trajectories (the product's
  ``FourierSeries``, designed by ``orthoglide_ident.excite``), test trajectories, the safe box.
- ``record``: ``simulate(...) -> SimRecord`` for bags and benchmarks; ``session`` + ``driver_node``:
  the ROS 2 driver.
"""

import orthoglide_ident  # noqa: E402,F401  one BLAS thread before numpy (orthoglide_ident/__init__.py)
