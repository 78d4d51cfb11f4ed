"""Dubins paths: the shortest paths of bounded curvature that only go forward (Dubins 1957).

Used for the trailer axle driven in reverse: the trailer steered by its virtual steer moves like a car
(Eq. 42), its axle along arcs of radius at least ``L_T / tan(virtual_limit)``; seen along its direction
of motion (heading ``yaw + pi``) a single reverse run is a forward Dubins path. The six words (LSL,
RSR, LSR, RSL, RLR, LRL) in closed form as in Shkel and Lumelsky (2001), "Classification of the Dubins
set"; every word that exists is returned, so a caller can try more than the shortest.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["dubins_words", "sample_word"]

_TAU = 2.0 * math.pi


def _mod(a: float) -> float:
    return a % _TAU


Pose2 = tuple[float, float, float]


def dubins_words(start: Pose2, end: Pose2, radius: float) -> list[tuple[str, Pose2]]:
    """Each Dubins word from ``start`` to ``end`` (x, y, heading) at ``radius``: (word, segment lengths [m]).

    Shortest first. A segment's length is the distance along it (arcs: radius times the angle turned).
    """
    dx, dy = end[0] - start[0], end[1] - start[1]
    d = math.hypot(dx, dy) / radius
    theta = math.atan2(dy, dx)
    a, b = _mod(start[2] - theta), _mod(end[2] - theta)
    sa, sb, ca, cb, cab = math.sin(a), math.sin(b), math.cos(a), math.cos(b), math.cos(a - b)
    words: list[tuple[str, Pose2]] = []

    def add(word: str, t: float, p: float, q: float) -> None:
        words.append((word, (t * radius, p * radius, q * radius)))

    tmp = 2 + d * d - 2 * cab + 2 * d * (sa - sb)  # LSL
    if tmp >= 0:
        phi = math.atan2(cb - ca, d + sa - sb)
        add("LSL", _mod(phi - a), math.sqrt(tmp), _mod(b - phi))
    tmp = 2 + d * d - 2 * cab + 2 * d * (sb - sa)  # RSR
    if tmp >= 0:
        phi = math.atan2(ca - cb, d - sa + sb)
        add("RSR", _mod(a - phi), math.sqrt(tmp), _mod(phi - b))
    tmp = -2 + d * d + 2 * cab + 2 * d * (sa + sb)  # LSR
    if tmp >= 0:
        p = math.sqrt(tmp)
        phi = math.atan2(-ca - cb, d + sa + sb) - math.atan2(-2.0, p)
        add("LSR", _mod(phi - a), p, _mod(phi - b))
    tmp = -2 + d * d + 2 * cab - 2 * d * (sa + sb)  # RSL
    if tmp >= 0:
        p = math.sqrt(tmp)
        phi = math.atan2(ca + cb, d - sa - sb) - math.atan2(2.0, p)
        add("RSL", _mod(a - phi), p, _mod(b - phi))
    tmp = (6 - d * d + 2 * cab + 2 * d * (sa - sb)) / 8  # RLR
    if abs(tmp) <= 1:
        p = _mod(_TAU - math.acos(tmp))
        t = _mod(a - math.atan2(ca - cb, d - sa + sb) + p / 2)
        add("RLR", t, p, _mod(a - b - t + p))
    tmp = (6 - d * d + 2 * cab - 2 * d * (sa - sb)) / 8  # LRL
    if abs(tmp) <= 1:
        p = _mod(_TAU - math.acos(tmp))
        t = _mod(-a - math.atan2(ca - cb, d + sa - sb) + p / 2)
        add("LRL", t, p, _mod(b - a - t + p))
    return sorted(words, key=lambda w: sum(w[1]))


def sample_word(start: Pose2, word: str, lengths: Pose2, radius: float, step: float) -> np.ndarray:
    """Points (x, y, heading), rows at most ``step`` apart, along a word from ``start`` (both ends included)."""
    x, y, h = start
    parts = [np.array([[x, y, h]], dtype=float)]
    for kind, length in zip(word, lengths, strict=True):
        n = max(1, math.ceil(length / step))
        s = np.arange(1, n + 1) * (length / n)
        if kind == "S":
            xs, ys, hs = x + s * math.cos(h), y + s * math.sin(h), np.full(n, h)
        else:
            turn = 1.0 if kind == "L" else -1.0
            hs = h + turn * s / radius
            xs = x + turn * radius * (np.sin(hs) - math.sin(h))
            ys = y - turn * radius * (np.cos(hs) - math.cos(h))
        parts.append(np.column_stack([xs, ys, hs]))
        x, y, h = float(xs[-1]), float(ys[-1]), float(hs[-1])
    return np.concatenate(parts)
