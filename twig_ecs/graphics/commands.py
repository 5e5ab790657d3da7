"""Click-commands: tell the selected character what to do with a clicked target.

The window's user selects a character (a click on it, or Tab), clicks a target - a
character, an object or a point on the ground - and picks a command by its number key
from a small menu. Each command but *look at* is a goal behaviour: the clicked target
goes into the goal schema's first name/target parameter (``hug(target)``,
``sit(on)``...), everything else keeps the schema's defaults, and the goal is queued
through the character handle's ``do`` with the same checks as from Python or RPC. So no
parameter list is written here; a goal the scene does not have is simply not offered.
*Look at* is the handle's immediate control (the head tracks the target at once).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twig_ecs.errors import TwigError

#: The commands in menu order (number keys 1..7): (label, goal behaviour or "look_at").
COMMANDS = (
    ("approach", "approach"),
    ("hug", "hug"),
    ("grapple", "grapple"),
    ("carry", "carry"),
    ("drag", "drag"),
    ("sit", "sit"),
    ("look at", "look_at"),
)


@dataclass(frozen=True)
class Target:
    """What a click chose: an entity by name, or a point on the ground (m)."""

    name: str | None = None
    point: tuple[float, float, float] | None = None

    def describe(self) -> str:
        """The target in words for the menu and the status line."""
        if self.name is not None:
            return self.name
        x, _, z = self.point
        return f"the ground at ({x:.1f}, {z:.1f})"


def target_param(schema):
    """The parameter of a goal schema that names what the goal is about (the first name/target one)."""
    for p in schema.params:
        if p.kind in ("name", "target"):
            return p
    return None


def available(scene) -> list[tuple[int, str, str]]:
    """The commands this scene can carry out, as (number key, label, behaviour)."""
    out = []
    for k, (label, behaviour) in enumerate(COMMANDS, start=1):
        system = scene.behaviors.get(behaviour)
        if behaviour == "look_at" or (system is not None and system.goal_driven and system.schema):
            out.append((k, label, behaviour))
    return out


def menu_lines(scene, actor: str, target: Target) -> list[str]:
    """The menu's lines: who does what to which target, one command per line."""
    lines = [f"{actor} -> {target.describe()}:"]
    lines += [f"  {k}  {label}" for k, label, _ in available(scene)]
    lines.append("  (click elsewhere: another target; Backspace: clear)")
    return lines


def issue(scene, actor: str, behaviour: str, target: Target):
    """Command ``actor`` to do ``behaviour`` to ``target``; returns the goal (None for look-at).

    Raises :class:`~twig_ecs.errors.TwigError` (said in the status line) when the goal
    cannot take this target, e.g. a hug of a point on the ground.
    """
    handle = scene.entity(actor)
    if not hasattr(handle, "do"):
        raise TwigError(f"'{actor}' is not a character: it takes no commands")
    value = target.name if target.name is not None else [float(v) for v in target.point]
    if behaviour == "look_at":
        handle.look_at(value)
        return None
    system = scene.behaviors.get(behaviour)
    if system is None or system.schema is None:
        raise TwigError(f"this scene has no '{behaviour}' goal")
    param = target_param(system.schema)
    if param is None:
        return handle.do(behaviour)
    if target.name is None and param.kind == "name":
        raise TwigError(f"{behaviour} needs an entity as its '{param.name}', not a point: click a body")
    return handle.do(behaviour, **{param.name: value})


def ground_target(point: np.ndarray) -> Target:
    """A target point on the ground from a picked world point."""
    return Target(point=(float(point[0]), 0.0, float(point[2])))
