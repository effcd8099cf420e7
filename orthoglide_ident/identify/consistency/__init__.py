"""Physically consistent standard parameters behind an identification (pseudo-inertia LMI)."""
