"""Component types: small dataclasses holding handles (store rows) and parameters.

Hot numbers live in the :class:`~twig_ecs.store.PhysicsState` arrays; components say
which rows belong to which entity and carry authoring parameters.
"""

from twig_ecs.components.attention import (
    Attachment,
    Feisty,
    Memory,
    Perception,
    Playful,
    Rider,
    Wander,
    Watchful,
)
from twig_ecs.components.behavior_state import (
    Glance,
    Kicking,
    LastFight,
    Spin,
    ToyHome,
    Withdrawing,
)
from twig_ecs.components.character import Character
from twig_ecs.components.physics import Body, GrabJoint, Name, PainSensor

__all__ = ["Attachment", "Body", "Character", "Feisty", "Glance", "GrabJoint", "Kicking",
           "LastFight", "Memory", "Name", "PainSensor", "Perception", "Playful", "Rider", "Spin", "ToyHome",
           "Wander", "Watchful", "Withdrawing"]  # fmt: skip
