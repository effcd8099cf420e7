"""Numerical identification (paper Sects. 3-4). Never imports rclpy.

    from orthoglide_ident.identify import identify, IdentifyOptions
    from orthoglide_ident.model.registry import load_robot
    robot = load_robot("ur5")                                   # a bundled name, a URDF, a YAML
    res = identify(["bags/unloaded", "bags/loaded"], model=robot)  # IDIM-TLS, payload from tags
    res.to_json(); res.to_text(); res.message_fields()          # docs/design/interfaces.md

Rooms by concern (docs/design/architecture.md), in the order a record goes through them:
``records/`` (bags and logs → Record, pairing, segments, the robot's checks), ``observe/``
(filtering, time base, sampling, reversals, decimation, smooth rows: a record → decimated rows
of [W | W_payload, v_τ]), ``columns/`` (the layout beside W: drive terms, current-loop lag,
payload unknowns), ``solve/`` (per-joint R factors, the methods table, TLS, WLS, IV, partial
answers, essential parameters, uncertainty), ``consistency/`` (physically consistent
parameters), ``validate/`` (record checks, cross-validation, direct dynamics). The offline
orchestration is ``pipeline.py``; the live one ``live/`` (shares every room above, never
``pipeline``). ``options.py`` holds the tuning (config/identification.yaml).

    live = LiveIdentification(model=robot)                      # identify/live/session.py
    live.start_recording("run-1", "unloaded"); live.add_joint_states(...); ...
"""
from orthoglide_ident.identify.live.session import LiveEstimate, LiveIdentification
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.identify.pipeline import identify, identify_records
from orthoglide_ident.identify.records.record import Record, read_record

__all__ = ["IdentifyOptions", "LiveEstimate", "LiveIdentification", "Record", "identify",
           "identify_records", "read_record"]
