"""Exciting trajectories for the user's robot (paper Sect. 3.2): the trajectory file, its design,
its check against the robot's limits, and its run through a joint_trajectory_controller."""
from orthoglide_ident.excite.trajectory import (
    ExcitationRun,
    ExcitationTrajectory,
    FourierSeries,
    load_trajectory,
    save_trajectory,
)

__all__ = ["ExcitationRun", "ExcitationTrajectory", "FourierSeries", "load_trajectory",
           "save_trajectory"]
