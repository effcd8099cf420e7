"""Simulated closed chains on MuJoCo: description, truth, plant and records."""
