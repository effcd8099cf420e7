"""The simulator: plants independent of the identification model, controllers, records, nodes.

Rooms (docs/design/simulator.md), each robot's with its description, truth, plant and records:

- ``common/``: one closed loop (1 kHz controller with zero-order hold, the plant integrated by
  RK4), one PID, one quantiser and the drive model (current noise, ripple), the stored exciting
  trajectories (the product's ``FourierSeries``, designed by ``orthoglide_ident.excite``);
  imports no robot room.
- ``orthoglide/``: the Orthoglide on Pinocchio (three P + 4R legs closed on the platform), its
  own numpy kinematics, the reduced per-tick plant, the sample bags (``make_bags``).
- ``arms/``, ``chains/``, ``coupled/``: serial arms, closed chains and the coupled wrist on
  MuJoCo (the independent plant), with Pinocchio truths.
- ``arm_or_chain/``: a robot file's records whichever it is (``python -m
  orthoglide_sim.arm_or_chain.bags``), the session and the design command above both.
- ``nodes/``: the ROS 2 driver, the ros2_control stand-ins and the trajectory action.
- ``demos/``: ``make demo`` and its siblings, each ending with a verdict line.
"""

import orthoglide_ident  # noqa: E402,F401  one BLAS thread before numpy (orthoglide_ident/__init__.py)
