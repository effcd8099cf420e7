"""Orthoglide simulator: plant dynamics from an independent formulation, controllers, trajectories."""
