"""The handle code's arithmetic over arrays, to the bit: for the batch forms of behaviours.

A behaviour's batch form (``act_batch``: every character it won this step at once) must write
what its per-character form (``act``, through the handle API) writes from the same state, bit
for bit, or a scene's trajectory moves. These are the handle code's operations over rows:
``math.hypot`` for ground distances (``ground_distance``; numpy's hypot is not CPython's),
numpy's ``vecdot`` for the lengths ``np.linalg.norm`` took (a BLAS dot a row, as ``norm``
makes: a sum of squares differs in the last bit for one vector in five), Python's ``**`` for a
root of the size, and :func:`steer_to_rows`, ``steer_to`` for many walkers in one
:func:`~twig_ecs.systems.control.steer.steer_rows` call. Used by grapple and defend (issue 36).
"""

from __future__ import annotations

import math

import numpy as np

from twig_ecs.rowtable import RowTable
from twig_ecs.systems.behaviours.approach import (
    steer_batch,
)
from twig_ecs.systems.behaviours.hug import mean_velocities
from twig_ecs.systems.control.steer import (
    ARRIVED,
)
from twig_ecs.validate import LIMIT

#: ``steer_to``'s steering gains: approach's (the same field and figures).
#: Multiplies a vector onto the ground plane (the handle code's ``* np.array([1.0, 0.0, 1.0])``).
GROUND = np.array([1.0, 0.0, 1.0])


def lengths(v: np.ndarray) -> np.ndarray:
    """Each row's ``np.linalg.norm``, to the bit (a BLAS dot a row, then the root)."""
    return np.sqrt(np.vecdot(v, v))


def units(v: np.ndarray) -> np.ndarray:
    """Each row ``v / |v|`` (``|v|`` as :func:`lengths`), or the row itself where it has no length."""
    n = lengths(v)
    long = n > 1e-9
    return np.where(long[:, None], v / np.where(long, n, 1.0)[:, None], v)


def ground_gaps(here: np.ndarray, there: np.ndarray) -> np.ndarray:
    """``ground_distance(here[k], there[k])`` of every row (``math.hypot``, as it takes it)."""
    dx, dz = (here[:, 0] - there[:, 0]).tolist(), (here[:, 2] - there[:, 2]).tolist()
    return np.array([math.hypot(x, z) for x, z in zip(dx, dz, strict=True)])


def roots(values: np.ndarray) -> np.ndarray:
    """``value ** 0.5`` of every value, as Python's power makes it (``scale**0.5``)."""
    return np.array([v**0.5 for v in values.tolist()])


def walkable(walk: np.ndarray, limit: np.ndarray) -> bool:
    """Would ``CharacterHandle.walk`` take every row of ``walk`` (finite, not too big, within the
    row's top speed ``limit``; a margin on the speed: the handle's own hypot decides)?"""
    return bool(np.isfinite(walk).all() and (np.abs(walk) <= LIMIT).all()
                and (np.hypot(walk[:, 0], walk[:, 2]) <= limit * (1.0 - 1e-9)).all())  # fmt: skip


def steer_to_rows(scene, crows: np.ndarray, memories: list[dict], targets: RowTable, at: np.ndarray,
                  here: np.ndarray, there: np.ndarray, stop: np.ndarray, speed: float):  # fmt: skip
    """``steer_to(character, goal, target, stop[k], speed=speed)`` for every row k at once:
    character ``crows[k]`` (its pelvis at ``here[k]``) walks to the character target of row
    ``at[k]`` of ``targets`` (columns ``body``, ``first``, ``count``, ``mass``: its body, its
    nodes and their mass, numpy's sum), whose pelvis is at ``there[k]``, pursuing it at its pace.

    Returns (walk vectors, which rows have arrived), the goals' ``memories`` (their stall clocks)
    updated as ``steer_to`` updates them; None, nothing written, when one has stalled or asks for
    a walk it cannot do (the per-character form fails the goal or says why)."""
    n = len(crows)
    if not n:
        return np.zeros((0, 3)), np.zeros(0, dtype=bool)
    direction = (here - there) * GROUND
    norm = lengths(direction)
    far = norm > 1e-9
    direction[far] /= norm[far, None]
    direction[~far] = 0.0  # (no length, no direction)
    steered = steer_batch(scene, crows, targets["body"][at], there, direction, stop, speed, memories)
    if steered is None:
        return None  # stalled (the goal fails), or a walk it cannot do
    w, walk, best, squeeze_until, now = steered
    arrived = w.status == ARRIVED
    going = np.flatnonzero(~arrived)
    if len(going):
        # pursuit: match the target's pace on top of closing in (BodyHandle.velocity's sums)
        t = at[going]
        velocity = np.empty((len(going), 3))
        nodes = scene.state.nodes
        mean_velocities(nodes.pos, nodes.prev, nodes.mass, targets["first"][t], targets["count"][t],
                        targets["mass"][t], scene.dt, velocity)  # fmt: skip
        walk[going] = walk[going] + velocity * GROUND
        pace = lengths(walk[going])
        fast = pace > speed
        walk[going[fast]] *= (speed / pace[fast])[:, None]
        walk[:, 1] = 0.0
    for k in going.tolist():
        m = memories[k]
        if w.best[k] != best[k]:
            m["best"], m["best_at"] = float(w.distance[k]), now
        else:
            m.setdefault("best_at", now)
        if w.squeeze_until[k] != squeeze_until[k]:
            m["squeeze_until"] = float(w.squeeze_until[k])
    return walk, arrived
