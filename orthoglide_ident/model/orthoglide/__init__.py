"""The Orthoglide: the paper's closed form (Sects. 2, 3.1, 5.1), one robot model among others.

Only the robot registry (``model/registry.py``) imports this package in the product; everything
else takes the robot as a :class:`~orthoglide_ident.model.robot.RobotModel`.

Vectorised over N samples; q, qd, qdd are (N, 3) arrays in m, m/s, m/s²:

- ``geometry``: ``Geometry`` (a, d4, d6, g: the robot file's), ``PAPER`` and its constants A, D4,
  D6, G0, GRAVITY; JOINT_NAMES, G_TAU_MANUFACTURER.
- ``kinematics``: ``fgm(q) -> P (N, 3)``, ``igm(P) -> q``, ``tree_state(q, qd, qdd)``;
  raise ``WorkspaceError`` / ``SingularityError`` (orthoglide_ident.errors).
- ``parameters``: ``STANDARD_NAMES`` (208 robot parameters), ``PAYLOAD_NAMES`` (10).
- ``idim``: ``standard_regressor(q, qd, qdd) -> (W_st (3N, 208), W_l (3N, 10))``, eqs. (15), (18).
- ``leg_closed_form``: the closed-form columns of one leg that the base model uses.
- ``base``: ``base_model() -> BaseModel`` with ``names``, ``expressions``, ``K`` (chi_b = K chi_st),
  ``regressor(q, qd, qdd) -> W (3N, n_b)``, ``payload_mass_column(q, qd, qdd) -> (3N,)``.
"""
