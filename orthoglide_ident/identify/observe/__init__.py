"""Observation: q̂, q̂̇, q̂̈ on the record's time base, W's rows, parallel decimation (eqs. 19-20)."""
