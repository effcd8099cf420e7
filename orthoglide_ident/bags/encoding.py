"""CDR encoding of the bags' messages in bulk (numpy): whole records (``encode_messages``,
``encode_joint_states``, ``encode_dynamic_joint_states``) and per-message templates whose stamp
and values are patched in place (``CdrTemplate``, ``MessageTemplate``; the driver's messages)."""
from __future__ import annotations

from ._encode import (
    CdrTemplate,
    MessageTemplate,
    encode_dynamic_joint_states,
    encode_joint_states,
    encode_messages,
)

__all__ = [
    "CdrTemplate",
    "MessageTemplate",
    "encode_dynamic_joint_states",
    "encode_joint_states",
    "encode_messages",
]
