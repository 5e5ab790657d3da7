"""What a character's behaviours are in the middle of: state components on the character.

A behaviour system keeps no per-character dicts: what it must remember about one
character between steps (a retreat under way, a go at the merry-go-round, where its
hands are reaching) is a component on that character's entity, added when the
behaviour starts something and removed when it is over. So a snapshot, the inspector
or another behaviour can see it (``scene.world.try_component(entity, Withdrawing)``), and it
dies with the entity. A behaviour's *parameters* stay in its own component
(:class:`~twig_ecs.components.Feisty`, :class:`~twig_ecs.components.Rider`...).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(slots=True)
class Withdrawing:
    """A pain withdrawal under way (systems/behaviours/withdraw.py): backing off, then walking away."""

    until: float  # s (scene time) the whole retreat ends
    stagger_until: float  # s the stagger back, facing the source, ends; it walks away after
    away: np.ndarray  # unit vector on the ground away from the source
    source: int  # entity of the body that hurt it


@dataclass(slots=True)
class LastFight:
    """When a feisty character last started a fight (systems/behaviours/fight.py: one per cooldown)."""

    at: float  # s (scene time)


@dataclass(slots=True)
class Glance:
    """An attached child's looks back at its caregiver (systems/behaviours/attachment.py)."""

    until: float = -1.0  # s the current glance ends (in the past: not glancing)
    last: float = -1e9  # s the last glance began


@dataclass(slots=True)
class Spin:
    """A child's go at the merry-go-round (systems/behaviours/ride.py): walk there, take hold, run round."""

    since: float  # s it got the urge
    phase: str = "go"  # go -> take -> run -> leave
    bar: str = ""  # the node of the ride it holds
    phase_since: float = 0.0
    hands: tuple = ()  # the hands it takes hold with
    run_out: float = 0.0  # m/s round the rim (signed, counter-clockwise seen from above) when it let go


@dataclass(slots=True)
class Kicking:
    """A child's game with its toy (systems/behaviours/play.py): where it wants the toy to go, its kick."""

    aim_at: np.ndarray  # where it sends the toy (m)
    kicked_at: float = -1e9
    chosen_at: float = 0.0  # s it chose ``aim_at``
    kick_ends: float = -1e9  # s the swinging foot lands
    foot: str = ""  # the foot that kicked last ('l_foot' or 'r_foot')
    speed_before: float = 0.0  # m/s of the toy before the kick
    counted: bool = True  # has the last kick been judged (touched or missed)?


@dataclass(slots=True)
class ToyHome:
    """Where a toy lay when play first sent it somewhere: with no fenced yard, kicks aim
    within a circle round it (on the toy's entity, systems/behaviours/play.py)."""

    at: np.ndarray
