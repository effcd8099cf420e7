"""Orthoglide online logging and IDIM-TLS identification of drive gains and dynamic parameters."""
__version__ = "0.1.0"
