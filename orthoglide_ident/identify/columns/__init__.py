"""The columns beside W: drive terms the IDIM lacks, the current lag, a payload's unknowns (Sect.
4.3)."""
