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
from twig_ecs.components.character import Character
from twig_ecs.components.physics import Body, GrabJoint, Name, PainSensor

__all__ = ["Attachment", "Body", "Character", "Feisty", "GrabJoint", "Memory", "Name", "PainSensor",
           "Perception", "Playful", "Rider", "Wander", "Watchful"]  # fmt: skip
