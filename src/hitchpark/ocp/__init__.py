"""What is optimised: the paper's trailer OCP, the full model's, its obstacle constraints and path references.

Each problem meets :class:`hitchpark.solvers.transcription.OCP`: a transcription turns it into an NLP and a
registered route solves it (:mod:`hitchpark.solvers`); the controllers that solve it each tick are in
:mod:`hitchpark.control`.
"""

from .full import FullParkingProblem
from .obstacles import ClearanceConstraints
from .reference import PathReference
from .settings import KIND_DEFAULTS, NMPC_KINDS, NMPCSettings
from .trailer import TrailerParkingProblem

__all__ = [
    "KIND_DEFAULTS",
    "NMPC_KINDS",
    "ClearanceConstraints",
    "FullParkingProblem",
    "NMPCSettings",
    "PathReference",
    "TrailerParkingProblem",
]
