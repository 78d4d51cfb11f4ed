"""Controllers: the trailer NMPC (Section 4) and the forward pure pursuit (Section 5)."""

from .nmpc import NMPCStep, Pose, TrailerNMPC, make_solver, to_goal_frame, wrap_angle
from .ocp import NMPCSettings, TrailerParkingProblem
from .transcription import MultipleShooting, SingleShooting, make_transcription

__all__ = [
    "MultipleShooting",
    "NMPCSettings",
    "NMPCStep",
    "Pose",
    "SingleShooting",
    "TrailerNMPC",
    "TrailerParkingProblem",
    "make_solver",
    "make_transcription",
    "to_goal_frame",
    "wrap_angle",
]
