"""Records: tagged bags and logs to a Record in memory, paired by stamp, split at gaps (Sect.
3.1)."""
