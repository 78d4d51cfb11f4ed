"""hitchpark: reverse parking of a car with a trailer.

Implements Cao et al. (2025), "Nonlinear Model Predictive Control-Based Reverse
Path-Planning and Path-Tracking Control of a Vehicle with Trailer System": the
kinematic vehicle-trailer model, its inverse kinematics, a trailer-only NMPC and
the 3-stage (reverse, forward, reverse) parking maneuver. Angles are radians.
"""

from .checks import InputError
from .maneuver import ManeuverResult, park
from .model import (
    VehicleTrailer,
    front_steer_from_virtual,
    load_vehicle,
    rear_speed_from_trailer_speed,
    virtual_steer_bounds,
    virtual_steer_from_front,
)
from .model.geometry import Pose
from .sim import State, Trajectory, simulate

__version__ = "0.1.0"

__all__ = [
    "InputError",
    "ManeuverResult",
    "Pose",
    "State",
    "Trajectory",
    "VehicleTrailer",
    "front_steer_from_virtual",
    "load_vehicle",
    "park",
    "rear_speed_from_trailer_speed",
    "simulate",
    "virtual_steer_bounds",
    "virtual_steer_from_front",
]
