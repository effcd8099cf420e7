"""Numerical identification pipeline (paper Sects. 3-4). Never imports rclpy.

    from orthoglide_ident.identify import identify, IdentifyOptions
    from orthoglide_ident.model.robots import load_robot
    robot = load_robot("orthoglide")                           # or a URDF, a robot YAML
    res = identify(["bags/unloaded", "bags/loaded"], model=robot)  # IDIM-TLS, payload from tags
    res.to_json(); res.to_text(); res.message_fields()         # docs/architecture.md §4 JSON, table, msg fields

One module per step: segments (pairing, gaps) → filtering (derivative filter, zero-order hold)
→ reversals (sign() friction at velocity reversals) → decimation (parallel decimation, eqs.
19-20) → tls / wls (eqs. 24-39) → uncertainty (σ that cover correlated residuals, next to eqs.
38-39's; the residual's autocorrelation and spectrum over position) → drive_terms (a screw
ripple found in the residual, added to the model) → essential (Sect. 5.2, keeping the gains) →
validation (Fig. 5); stream runs a segment through filtering, W, reversals and decimation block
by block, factors keeps the equations as per-joint R factors (and the residual moments), solve
turns them into a result; pipeline ties them together for bags, live (with pairing and
live_recording) while recording; options holds the tuning (config/identification.yaml).

    live = LiveIdentification(model=robot)           # see identify/live.py
    live.start_recording("run-1", "unloaded"); live.add_joint_states(...); ...
"""
from orthoglide_ident.identify.live import LiveEstimate, LiveIdentification
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.identify.pipeline import identify, identify_records
from orthoglide_ident.identify.records import Record, read_record

__all__ = ["IdentifyOptions", "LiveEstimate", "LiveIdentification", "Record", "identify",
           "identify_records", "read_record"]
