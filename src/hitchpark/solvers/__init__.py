"""How an optimal control problem is solved: transcriptions into NLPs and a registry of named solver routes.

The routes are CasADi's (IPOPT, sqpmethod, fatrop), the same generated to C and compiled, and hitchpark's own
structured interior-point method (``riccati_c``). Nothing here knows of parking: a problem is anything that
meets :class:`~.transcription.OCP`. Add a route with :func:`register_solver`.
"""

from .registry import ROUTES, Route, make_solver, register_solver, solver_names
from .transcription import OCP, MultipleShooting, SingleShooting, Transcription, make_transcription

__all__ = [
    "OCP",
    "ROUTES",
    "MultipleShooting",
    "Route",
    "SingleShooting",
    "Transcription",
    "make_solver",
    "make_transcription",
    "register_solver",
    "solver_names",
]
