"""Who acts each tick: the reverse NMPCs (the paper's trailer-only one, Section 4, and the full-model one), the
forward pure pursuit (Section 5), the planned path's tracker and the guard that keeps the car clear of the scene.

What they optimise is in :mod:`hitchpark.ocp`, how it is solved in :mod:`hitchpark.solvers`; the names a user
imported from here before those were apart are here too (``NMPCSettings``, ``PathReference``, ``make_solver``).
"""

from ..ocp.full import FullParkingProblem
from ..ocp.reference import PathReference
from ..ocp.settings import NMPCSettings
from ..ocp.trailer import TrailerParkingProblem
from ..solvers.registry import ROUTES, make_solver, register_solver
from ..solvers.transcription import MultipleShooting, SingleShooting, make_transcription
from .estimator import Estimator, EstimatorSettings
from .nmpc import FullNMPC, NMPCStep, TrailerNMPC, make_nmpc
from .pure_pursuit import ForwardPursuit, PurePursuitSettings
from .step import Controller, ControlStep

__all__ = [
    "ROUTES",
    "ControlStep",
    "Controller",
    "Estimator",
    "EstimatorSettings",
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
