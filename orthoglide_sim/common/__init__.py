"""What every simulated robot shares: the 1 kHz clock, ticks ahead, packed messages,
trajectories."""
