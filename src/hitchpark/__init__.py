"""hitchpark: reverse parking of a car with a trailer.

Implements Cao et al. (2025), "Nonlinear Model Predictive Control-Based Reverse
Path-Planning and Path-Tracking Control of a Vehicle with Trailer System": the
kinematic vehicle-trailer model, its inverse kinematics, a trailer-only NMPC and
the 3-stage (reverse, forward, reverse) parking maneuver; beyond it, a full-model NMPC
that drives a realistic car (steering and speed actuators, delay, sensor noise, wrong
lengths). Angles are radians.
"""

from .checks import InputError
from .maneuver import ManeuverResult, park
from .model import (
    PlantSettings,
    Pose,
    State,
    VehicleTrailer,
    front_steer_from_virtual,
    load_plant,
    load_vehicle,
    rear_speed_from_trailer_speed,
    virtual_steer_bounds,
    virtual_steer_from_front,
)
from .model.simulate import Trajectory, simulate

__version__ = "0.1.0"

__all__ = [
    "InputError",
    "ManeuverResult",
    "PlantSettings",
    "Pose",
    "State",
    "Trajectory",
    "VehicleTrailer",
    "front_steer_from_virtual",
    "load_plant",
    "load_vehicle",
    "park",
    "rear_speed_from_trailer_speed",
    "simulate",
    "virtual_steer_bounds",
    "virtual_steer_from_front",
]
