"""What a system sees: the context of one step, and the scene's services as an interface.

Each step the scene builds one :class:`StepContext` - the step's length and time, the
world's entities, the physics store, the RNG, the settings and the event bus - and hands
it to every system's :meth:`~twig_ecs.system.System.run`, as Box2D v3 passes its
``b2StepContext``: a system reads what it needs from the context, not from the scene.

:class:`SceneView` is the part of a scene that handles, behaviours and systems may call
(names, handles, goals, grabs, events). It is a :class:`typing.Protocol`, so the layers
below the scene name the scene's type without importing it (an import from below would
close a loop, even one made only for type checking).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    import numpy as np

    from twig_ecs.events import Event, EventBus
    from twig_ecs.store import PhysicsState
    from twig_ecs.world import World


@dataclass(slots=True, frozen=True)
class StepContext:
    """One step's inputs, the same for every system of that step.

    ``time`` is the simulated time at the start of the step (``frame * dt``); ``scene``
    gives the services a step may need beyond data (handles by entity, names, goals).
    """

    dt: float
    frame: int
    time: float
    world: World
    state: PhysicsState
    rng: np.random.Generator
    settings: Any
    events: EventBus
    scene: SceneView

    def emit(self, event: Event) -> None:
        """Send ``event`` to the scene's subscribers (and this step's event list)."""
        self.scene.emit(event)


class SceneView(Protocol):
    """What the layers below the scene use of it (the :class:`~twig_ecs.scene.Scene` has it all)."""

    world: World
    state: PhysicsState
    settings: Any
    rng: np.random.Generator
    frame: int
    dt: float
    behaviors: dict[str, Any]
    schedule: Any
    library: Any

    @property
    def time(self) -> float: ...

    @property
    def events(self) -> list[Event]: ...

    def check_open(self) -> None: ...
    def emit(self, event: Event) -> None: ...
    def entity(self, name: str) -> Any: ...
    def has_entity(self, name: str) -> bool: ...
    def entity_names(self) -> list[str]: ...
    def entity_id(self, name: str) -> int | None: ...
    def name_of(self, entity: int) -> str | None: ...
    def character_handle(self, entity: int) -> Any: ...
    def goal_holders_of(self, behavior: str) -> list[tuple[int, Any]]: ...
    def note_goal(self, entity: int, mind: Any) -> None: ...
    def new_goal_id(self) -> int: ...
    def end_goal(self, character: Any, goal: Any, ok: bool = True, reason: str = "") -> None: ...
    def spawn(self, template: str, *args: Any, **kwargs: Any) -> Any: ...
    def grab(self, holder: str, node: str, target: str, target_node: str, standoff: float = 0.0) -> int: ...
    def release(self, grab: int) -> None: ...
    def on(self, kind: str, handler: Callable[[Event], None]) -> None: ...
    def add_system(
        self, system: Any, name: str | None = None, before: Any = None, after: Any = None
    ) -> Any: ...
