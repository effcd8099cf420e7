"""Solving: per-joint R factors, IDIM-TLS/WLS, partial answers, essential parameters, sigma (eqs.
24-39)."""
