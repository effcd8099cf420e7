"""Numerical identification pipeline (paper Sects. 3-4). Never imports rclpy.

    from orthoglide_ident.identify import identify, IdentifyOptions
    res = identify(["bags/unloaded", "bags/loaded"])          # IDIM-TLS, payload from the tags
    res.to_json(); res.to_text(); res.message_fields()         # DESIGN §4 JSON, table, msg fields

One module per step: segments (pairing, gaps) → filtering (derivative filter, zero-order hold)
→ reversals (sign() friction at velocity reversals) → decimation (parallel decimation, eqs.
19-20) → tls / wls (eqs. 24-39) → essential (Sect. 5.2) → validation (Fig. 5); pipeline ties
them together, options holds the tuning (config/identification.yaml).
"""
from orthoglide_ident.identify.options import IdentifyOptions
from orthoglide_ident.identify.pipeline import Record, identify, identify_records, read_record

__all__ = ["IdentifyOptions", "Record", "identify", "identify_records", "read_record"]
