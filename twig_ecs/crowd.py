"""A behaviour's characters as arrays: the batch form of the character handle.

A plug-in behaviour that defines ``act_crowd(self, crowd)`` (and, if it likes,
``propose_crowd(self, crowd)``) gets every character it won this step (or may propose for)
in one :class:`Crowd`: read where they stand as ``(n, 3)`` arrays, write what they do with
one call each - ``crowd.walk(velocities)``, ``crowd.look_at(points)`` - the same writes
:class:`~twig_ecs.character.CharacterHandle`'s ``walk`` and ``look_at`` make for one. A
step then costs a few numpy calls for a thousand strollers instead of a thousand Python
calls (docs/authoring-behaviours.md, "A behaviour over arrays").
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import astuple, fields, is_dataclass
from typing import Any

import numpy as np

from twig_ecs.character import ARM_POSES, HANDS
from twig_ecs.components import Character
from twig_ecs.errors import TwigError
from twig_ecs.kernelmath import ARM_MODES, GAZE_AHEAD, GAZE_POINT, L_HIP, PELVIS, R_HIP, SIT, WAVE


class Crowd:
    """Characters ``entities`` (rows ``rows`` of the store's character table) of one behaviour.

    ``goals`` is each one's current goal of the behaviour (None where it has none, and for a
    behaviour no goal drives); ``dt`` the step (s). Arrays read from it are copies.
    """

    def __init__(self, scene, rows: Sequence[int], entities: Sequence[int], dt: float,
                 goals: Sequence[Any] | None = None, component: type | None = None) -> None:  # fmt: skip
        self.scene, self.dt, self.component = scene, dt, component
        self.rows = np.asarray(rows, dtype=np.int64)
        self.entities = list(entities)
        self.goals = list(goals) if goals is not None else [None] * len(self.entities)

    def __len__(self) -> int:
        return len(self.entities)

    # -- reading ------------------------------------------------------------------------------

    def _node(self, role: int) -> np.ndarray:
        ch = self.scene.state.characters
        return self.scene.state.nodes.pos[ch.nodes[self.rows, role]]

    @property
    def positions(self) -> np.ndarray:
        """Pelvis centres, ``(n, 3)`` (m)."""
        return self._node(PELVIS).copy()

    @property
    def facing(self) -> np.ndarray:
        """Unit ground vectors the pelvises face, ``(n, 3)``: (left hip - right hip) x up."""
        left = self._node(L_HIP) - self._node(R_HIP)
        f = np.stack([-left[:, 2], np.zeros(len(left)), left[:, 0]], axis=1)
        norm = np.linalg.norm(f, axis=1, keepdims=True)
        return f / np.where(norm > 0.0, norm, 1.0)

    @property
    def max_speeds(self) -> np.ndarray:
        """Each one's top walking speed (m/s)."""
        world = self.scene.world
        return np.array([world.component_for_entity(e, Character).max_speed for e in self.entities])

    def settings(self, name: str | None = None) -> Any:
        """The behaviour's component of each (its per-character parameters), or, given a
        field ``name``, that field of all of them as an array (``(n,)``, or ``(n, k)`` for a
        tuple field such as a centre)."""
        if self.component is None:
            raise TwigError("this behaviour has no component: its characters have no settings")
        world = self.scene.world
        found = [world.component_for_entity(e, self.component) for e in self.entities]
        if name is None:
            return found
        if is_dataclass(self.component) and name not in {f.name for f in fields(self.component)}:
            raise TwigError(f"{self.component.__name__} has no field '{name}'")
        values = [getattr(c, name) for c in found]
        return np.array([astuple(v) if is_dataclass(v) else v for v in values], dtype=np.float64)

    # -- writing ------------------------------------------------------------------------------

    def walk(self, velocities: Any) -> None:
        """Walk each with its ground velocity, ``(n, 2)`` as (x, z) or ``(n, 3)`` (y ignored),
        m/s; those sitting stand up first. A speed past a character's top speed, or a value
        that is not finite, is a TwigError naming it (nothing is written then)."""
        v = np.array(velocities, dtype=np.float64)
        if v.ndim != 2 or v.shape[0] != len(self) or v.shape[1] not in (2, 3):
            raise TwigError(
                f"walk velocities: give {len(self)} rows of (x, z) or (x, y, z), got shape {v.shape}"
            )
        if v.shape[1] == 2:
            v = np.stack([v[:, 0], np.zeros(len(v)), v[:, 1]], axis=1)
        v[:, 1] = 0.0
        speed = np.hypot(v[:, 0], v[:, 2])
        limit = self.max_speeds
        bad = np.flatnonzero(~np.isfinite(speed) | (speed > limit))
        if len(bad):
            k = int(bad[0])
            name = self.scene.name_of(self.entities[k]) or str(self.entities[k])
            raise TwigError(f"walk speed {speed[k]:.2f} m/s is more than '{name}' can do ({limit[k]} m/s)")
        ch = self.scene.state.characters
        ch.walk[self.rows] = v
        for k in np.flatnonzero(ch.mode[self.rows] == SIT):
            self.scene.character_handle(self.entities[int(k)]).stand()

    def stop(self) -> None:
        """Stand still, every one."""
        self.scene.state.characters.walk[self.rows] = 0.0

    def look_at(self, points: Any) -> None:
        """Face these points, ``(n, 3)`` (m)."""
        p = np.array(points, dtype=np.float64)
        if p.shape != (len(self), 3) or not np.isfinite(p).all():
            raise TwigError(f"look-at points: give {len(self)} finite rows of (x, y, z), got shape {p.shape}")
        ch = self.scene.state.characters
        ch.gaze_point[self.rows] = p
        ch.gaze_mode[self.rows] = GAZE_POINT

    def look_ahead(self) -> None:
        """Look where each goes."""
        self.scene.state.characters.gaze_mode[self.rows] = GAZE_AHEAD

    def pose(self, name: str, hands: str | Sequence[str] = "both") -> None:
        """Hold arms in a pose (``hang``, ``grapple``, ``hug``, ``carry``): ``hands`` is
        "left", "right" or "both" for all of them, or one of those for each."""
        if name not in ARM_POSES:
            raise TwigError(f"unknown arm pose '{name}' (one of {', '.join(ARM_POSES)})")
        self._set_arms(ARM_MODES[name], hands)

    def wave(self, hands: str | Sequence[str] = "right") -> None:
        """Wave (``hands`` as for :meth:`pose`)."""
        self._set_arms(WAVE, hands)

    def _set_arms(self, mode: int, hands: str | Sequence[str]) -> None:
        which = np.array([hands] * len(self) if isinstance(hands, str) else list(hands), dtype=object)
        if len(which) != len(self) or not set(which.tolist()) <= set(HANDS):
            raise TwigError(f"hands: give 'left', 'right' or 'both', for all or for each of {len(self)}")
        arm_mode = self.scene.state.characters.arm_mode
        for side, columns in HANDS.items():
            rows = self.rows[which == side]
            for column in columns:
                arm_mode[rows, column] = mode
