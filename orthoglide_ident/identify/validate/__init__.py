"""Validation: cross-validation on a record not used (paper Fig. 5) and direct-dynamic checks."""
