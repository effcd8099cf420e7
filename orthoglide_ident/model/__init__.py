"""Robot models: the interface every robot implements, and the Orthoglide's closed form.

- ``robot``: ``RobotModel`` (joints, standard and base parameters, the IDIM block for samples),
  ``ActuatedJoint``, ``Body``, ``Payload`` — what identify/, control, the nodes and the CLI use;
- ``robots``: ``load_robot(spec)`` for ``--robot`` / the ``robot`` parameter (docs/architecture.md §8).

The Orthoglide's closed form (paper Sects. 2, 3.1, 5.1), vectorised over N samples; q, qd, qdd are
(N, 3) arrays in m, m/s, m/s²:

- ``geometry``: ``Geometry`` (a, d4, d6, g: the robot file's), ``PAPER`` and its constants A, D4,
  D6, G0, GRAVITY; JOINT_NAMES, G_TAU_MANUFACTURER.
- ``kinematics``: ``fgm(q) -> P (N, 3)``, ``igm(P) -> q``, ``tree_state(q, qd, qdd)``;
  raise ``WorkspaceError`` / ``SingularityError`` (orthoglide_ident.errors).
- ``parameters``: ``STANDARD_NAMES`` (208 robot parameters), ``PAYLOAD_NAMES`` (10).
- ``idim``: ``standard_regressor(q, qd, qdd) -> (W_st (3N, 208), W_l (3N, 10))``, eqs. (15), (18).
- ``base``: ``base_model() -> BaseModel`` with ``names``, ``expressions``, ``K`` (chi_b = K chi_st),
  ``regressor(q, qd, qdd) -> W (3N, n_b)``, ``payload_mass_column(q, qd, qdd) -> (3N,)``.
"""
