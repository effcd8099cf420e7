"""Robot models: the interface every robot implements, what every robot shares, and the robots.

- ``robot``: ``RobotModel`` (joints, standard and base parameters, the IDIM block for samples),
  ``ActuatedJoint``, ``Body``, ``Payload`` — what identify/, control, the nodes and the CLI use;
- ``robots``: ``load_robot(spec)`` for ``--robot`` / the ``robot`` parameter
(docs/design/architecture.md
  §8), the one registry of robot kinds;
- the general model on Pinocchio (``pinocchio_model``, ``tree``, ``tree_regressor``, ``closure``,
  ``loop_constraints``, ``robot_file``) and what every robot shares: base parameters by QR
  (``base_parameters``), the identified URDF (``urdf``);
- ``orthoglide/``: the Orthoglide's closed form (paper Sects. 2, 3.1, 5.1), a robot package.
"""
from orthoglide_ident.model.registry import bundled_robots, load_robot
from orthoglide_ident.model.robot import ActuatedJoint, Body, Payload, RobotModel

__all__ = ["ActuatedJoint", "Body", "Payload", "RobotModel", "bundled_robots", "load_robot"]
