"""Vehicle-trailer model: parameters, states and poses, kinematics (Section 2), inverse kinematics
(Section 3), the plant (the simulated car with actuators and sensors), and the scene around it
(obstacles, the area to stay inside, exact clearance)."""

from .collision import clearance, swept_clearance
from .geometry import body_outlines
from .integrate import plant_function, rk4, step_full
from .inverse import (
    actual_virtual_steer,
    front_steer_from_virtual,
    rear_speed_from_trailer_speed,
    steady_hitch_from_virtual,
    trailer_speed_from_virtual,
    vehicle_yaw_rate_from_virtual,
    virtual_steer_bounds,
    virtual_steer_from_front,
)
from .kinematics import (
    FULL_INPUT,
    FULL_STATE,
    TRAILER_INPUT,
    TRAILER_STATE,
    full_rates,
    full_rhs,
    hitch_point,
    rear_axle_pose,
    trailer_rhs,
    trailer_speed_from_rear_speed,
)
from .plant import IDEAL, Command, Measurement, Plant, PlantSettings, load_plant
from .scene import Area, Obstacle, Scene
from .state import Pose, State, check_pose, check_state, to_goal_frame, wrap_angle
from .vehicle import VehicleTrailer, load_vehicle, vehicle_from_dict

__all__ = [
    "FULL_INPUT",
    "FULL_STATE",
    "IDEAL",
    "TRAILER_INPUT",
    "TRAILER_STATE",
    "Area",
    "Command",
    "Measurement",
    "Obstacle",
    "Plant",
    "PlantSettings",
    "Pose",
    "Scene",
    "State",
    "VehicleTrailer",
    "actual_virtual_steer",
    "body_outlines",
    "check_pose",
    "check_state",
    "clearance",
    "front_steer_from_virtual",
    "full_rates",
    "full_rhs",
    "hitch_point",
    "load_plant",
    "load_vehicle",
    "plant_function",
    "rear_axle_pose",
    "rear_speed_from_trailer_speed",
    "rk4",
    "steady_hitch_from_virtual",
    "step_full",
    "swept_clearance",
    "to_goal_frame",
    "trailer_rhs",
    "trailer_speed_from_rear_speed",
    "trailer_speed_from_virtual",
    "vehicle_from_dict",
    "vehicle_yaw_rate_from_virtual",
    "virtual_steer_bounds",
    "virtual_steer_from_front",
    "wrap_angle",
]
