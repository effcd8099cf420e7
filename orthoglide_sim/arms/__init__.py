"""Simulated serial arms on MuJoCo: description, truth, plant, controller, records and logs."""
