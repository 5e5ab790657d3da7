"""Component types shared across layers: small dataclasses holding handles (store rows) and parameters.

Hot numbers live in the :class:`~twig_ecs.store.PhysicsState` arrays; components say
which rows belong to which entity and carry authoring parameters. A component that
belongs to one behaviour (its parameters, what it is in the middle of) lives in that
behaviour's module in ``systems/behaviours/`` (``Playful`` in ``play``, ``Withdrawing``
in ``withdraw``...); here are those that several layers read: bodies, characters, grab
joints, attention and memory, and the attachment that attention weighs.
"""

from twig_ecs.components.attention import Attachment, Memory, Perception
from twig_ecs.components.character import Character
from twig_ecs.components.physics import Body, GrabJoint, Name, PainSensor

__all__ = ["Attachment", "Body", "Character", "GrabJoint", "Memory", "Name", "PainSensor", "Perception"]
