"""rosbag2/MCAP bags: tagged writing, fast reading, info, recovery (docs/design/interfaces.md).

No rclpy here. Files are written by the official MCAP library as rosbag2's MCAP storage plugin
writes them (``_mcapfile``, ``_metadata``) and read by a fast crash-tolerant scanner (``_mcap``);
message definitions and type hashes come from rosbags' typestore (reading: from the bag's own
schemas); q and the current are decoded in bulk with numpy (``_cdr``, ``_decode``) from the
Orthoglide's topics or a ros2_control robot's, as :mod:`.sources` chooses.

- :func:`write_bag` — a whole record at once (the simulator's sample bags).
- :class:`BagWriter` — streaming, chunked, split-capable writer (the recorder).
- :func:`read_bag` → :class:`BagData`; :func:`bag_info` → :class:`BagInfo`.
- :func:`reindex` — close cut-short files, rebuild metadata.yaml.
- :class:`BagSources` — which topics and fields a record's q and current come from.
- :class:`Recording` — a recording in progress.
- :mod:`.topics` (topic names, message types, QoS), :mod:`.tags` (tag keys and values,
  :class:`BagTags`), :mod:`.encoding` (bulk CDR encoding); the rest in the submodules that
  define it (:mod:`.reader`, :mod:`.info`, :mod:`.reindex`, :mod:`.sources`, :mod:`.writer`).
"""

from __future__ import annotations

from . import encoding, tags, topics
from ._tags import BagTags
from .info import BagInfo, bag_info
from .reader import BagData, read_bag
from .recording import Recording
from .reindex import reindex
from .sources import BagSources
from .writer import BagWriter, write_bag

__all__ = [
    "BagData",
    "BagInfo",
    "BagSources",
    "BagTags",
    "BagWriter",
    "Recording",
    "bag_info",
    "encoding",
    "read_bag",
    "reindex",
    "tags",
    "topics",
    "write_bag",
]
