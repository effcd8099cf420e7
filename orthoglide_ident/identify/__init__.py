"""Numerical identification pipeline (paper Sects. 3-4). Never imports rclpy.

    from orthoglide_ident.identify import identify, IdentifyOptions
    from orthoglide_ident.model.robots import load_robot
    robot = load_robot("orthoglide")                           # or a URDF, a robot YAML
    res = identify(["bags/unloaded", "bags/loaded"], model=robot)  # IDIM-TLS, payload from tags
    res.to_json(); res.to_text(); res.message_fields()         # docs/design/interfaces.md JSON,
    table, msg fields

Rooms by concern (docs/design/architecture.md §1): reading records (records: bags → Record),
observation
(observe, with segments, filtering, reversals, decimation, stream, drive_terms, current_lag: a
record → decimated rows of [W | W_payload, v_τ]), equations (factors: per-joint R factors),
solving (methods: the table of methods, dispatching to solve → tls / wls, uncertainty,
essential, consistency), results (diagnostics, validation, direct_dynamics). The offline path
(pipeline) and the live one (live, live_recording, pairing) share the observation and solving
rooms; neither imports the other. options holds the tuning (config/identification.yaml).

    live = LiveIdentification(model=robot)           # see identify/live.py
    live.start_recording("run-1", "unloaded"); live.add_joint_states(...); ...
"""
from orthoglide_ident.identify.live.session import LiveEstimate, LiveIdentification
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.identify.pipeline import identify, identify_records
from orthoglide_ident.identify.records.record import Record, read_record

__all__ = ["IdentifyOptions", "LiveEstimate", "LiveIdentification", "Record", "identify",
           "identify_records", "read_record"]
