"""Online identification: the offline pipeline fed while the recordings run."""
