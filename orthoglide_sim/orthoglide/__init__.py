"""The simulated Orthoglide: its own kinematics, closed-loop plant, truth, records and sample
bags."""
