"""Controllers: the reverse NMPCs (the paper's trailer-only one, Section 4, and the full-model one) and the
forward pure pursuit (Section 5), with their OCPs, transcriptions and solver registry, and the planned
path as the full NMPC's reference."""

from .full_ocp import FullParkingProblem
from .nmpc import FullNMPC, NMPCStep, TrailerNMPC, make_nmpc
from .ocp import NMPCSettings, TrailerParkingProblem
from .pure_pursuit import ForwardPursuit, PurePursuitSettings
from .reference import PathReference
from .solvers import ROUTES, make_solver, register_solver
from .transcription import MultipleShooting, SingleShooting, make_transcription

__all__ = [
    "ROUTES",
    "ForwardPursuit",
    "FullNMPC",
    "FullParkingProblem",
    "MultipleShooting",
    "NMPCSettings",
    "NMPCStep",
    "PathReference",
    "PurePursuitSettings",
    "SingleShooting",
    "TrailerNMPC",
    "TrailerParkingProblem",
    "make_nmpc",
    "make_solver",
    "make_transcription",
    "register_solver",
]
