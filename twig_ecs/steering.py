"""Steering's figures (SPEC 4): the gains of the approach field, and the ground distance.

``w = a + r`` with the attraction ``a = g - p`` (g: the goal point, the target plus the
stop distance along the approach direction), saturated at the walking speed, and the
repulsion from each obstacle o nearer than the cut-off::

    r = sum c * ((p - o) + (p - o) x e_y) / max(d_min, |p - o|^2)

The cross product with the vertical adds a sideways "curl" that steers round an
obstacle instead of stalling in front of it. Everything is on the ground plane. The one
implementation is :func:`twig_ecs.kernelmath.approach_field`, which the steering kernel
(:func:`twig_ecs.systems.control.steer.steer_rows`) calls for every walker.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, slots=True)
class SteeringParams:
    """Gains of the approach field (metres, seconds)."""

    speed: float = 1.3  # m/s: the attraction saturates here
    repulsion: float = 0.6  # c: strength of an obstacle's push (m^2/s)
    cutoff: float = 1.8  # m: obstacles further off are ignored
    min_sq: float = 0.15  # d_min (m^2): keeps the push finite up close
    curl: bool = True  # add the sideways term
    fade: float = 1.0  # m from the goal within which repulsion fades out


def ground_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Distance between two points on the ground plane."""
    return math.hypot(a[0] - b[0], a[2] - b[2])
