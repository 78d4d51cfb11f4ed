"""Who acts each tick: the reverse NMPCs (the paper's trailer-only one, Section 4, and the full-model one), the
forward pure pursuit (Section 5), the planned path's tracker and the guard that keeps the car clear of the scene.

What they optimise is in :mod:`hitchpark.ocp`, how it is solved in :mod:`hitchpark.solvers`; the names the
README showed users importing from here before those were apart are here too, until the next release
(``NMPCSettings``, ``PathReference``, ``ROUTES``, ``register_solver``).
"""

from ..ocp.reference import PathReference
from ..ocp.settings import NMPCSettings
from ..solvers.registry import ROUTES, register_solver
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
    "NMPCSettings",
    "NMPCStep",
    "PathReference",
    "PurePursuitSettings",
    "TrailerNMPC",
    "make_nmpc",
    "register_solver",
]
