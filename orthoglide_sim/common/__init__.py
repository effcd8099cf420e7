"""What every simulated robot shares: the one closed loop, PID and quantiser (closed_loop), the
drive model (drive), the 1 kHz clock, ticks ahead, packed messages, trajectories, and the stored
exciting trajectories' design by the product's designer (designs)."""
