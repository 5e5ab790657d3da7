"""Steering for approach (SPEC 4): attraction to a goal point plus curl repulsion.

``w = a + r`` with the attraction ``a = g - p`` (g: the goal point, the target plus the
stop distance along the approach direction), saturated at the walking speed, and the
repulsion from each obstacle o nearer than the cut-off::

    r = sum c * ((p - o) + (p - o) x e_y) / max(d_min, |p - o|^2)

The cross product with the vertical adds a sideways "curl" that steers round an
obstacle instead of stalling in front of it. Everything is on the ground plane.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twig_ecs.kernelmath import approach_field


@dataclass(frozen=True, slots=True)
class SteeringParams:
    """Gains of the approach field (metres, seconds)."""

    speed: float = 1.3  # m/s: the attraction saturates here
    repulsion: float = 0.6  # c: strength of an obstacle's push (m^2/s)
    cutoff: float = 1.8  # m: obstacles further off are ignored
    min_sq: float = 0.15  # d_min (m^2): keeps the push finite up close
    curl: bool = True  # add the sideways term
    fade: float = 1.0  # m from the goal within which repulsion fades out


def approach_velocity(position: np.ndarray, goal: np.ndarray, obstacles: np.ndarray,
                      params: SteeringParams = SteeringParams()) -> np.ndarray:  # fmt: skip
    """Walk vector (x, 0, z) towards ``goal`` around ``obstacles`` ((n, 3) points)."""
    # one compiled implementation of the field, shared with the crowd's wander behaviour
    obstacles = np.ascontiguousarray(obstacles, dtype=np.float64).reshape(-1, 3)
    wx, wz = approach_field(float(position[0]), float(position[2]), float(goal[0]), float(goal[2]),
                            obstacles, len(obstacles), params.speed, params.repulsion, params.cutoff,
                            params.min_sq, params.curl, params.fade)  # fmt: skip
    return np.array([wx, 0.0, wz])


def length(v: np.ndarray) -> float:
    """The length of a vector (a 1-d float array): ``np.linalg.norm``'s arithmetic (the root of
    ``v.dot(v)``, to the last bit) without its checks, which cost ten times the sum on three
    numbers in a behaviour's per-step Python."""
    return math.sqrt(v.dot(v))


def ground_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Distance between two points on the ground plane."""
    return math.hypot(a[0] - b[0], a[2] - b[2])
