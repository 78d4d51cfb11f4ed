"""Knob assist for backing up (Ford's Pro Trailer Backup Assist, in the open): the driver's knob steers the
trailer's path, the car turns its wheels, keeps out of a jackknife and stops for obstacles.

``KnobAssist(vehicle, settings, scene).step(measurement, knob, speed_request)`` in a loop of your own;
:mod:`hitchpark.control.assist` says how it works.
"""

from .control.assist import OVERRIDES, AssistSettings, AssistStep, KnobAssist, max_curvature

__all__ = ["OVERRIDES", "AssistSettings", "AssistStep", "KnobAssist", "max_curvature"]
