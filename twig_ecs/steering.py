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
    a = (goal - position) * np.array([1.0, 0.0, 1.0])
    dist = float(np.linalg.norm(a))
    # saturate: full speed far away, slowing over the last metre
    a = a / dist * min(params.speed, params.speed * dist) if dist > 1e-9 else np.zeros(3)
    r = np.zeros(3)
    if len(obstacles):
        off = (position - obstacles) * np.array([1.0, 0.0, 1.0])
        sq = (off**2).sum(axis=1)
        near = sq < params.cutoff**2
        if near.any():
            off, sq = off[near], sq[near]
            push = off.copy()
            if params.curl:
                push += np.stack([-off[:, 2], np.zeros(len(off)), off[:, 0]], axis=1)  # off x e_y
            r = (params.repulsion * push / np.maximum(params.min_sq, sq)[:, None]).sum(axis=0)
            # near the goal the push fades (quadratically: a grown-up standing by a ball
            # would otherwise keep a child circling it), so a crowd round the target
            # cannot hold one off a metre short
            r *= min(1.0, dist / params.fade) ** 2
    w = a + r
    speed = float(np.linalg.norm(w))
    if speed > params.speed:
        w *= params.speed / speed
    return w


def ground_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Distance between two points on the ground plane."""
    return math.hypot(a[0] - b[0], a[2] - b[2])
