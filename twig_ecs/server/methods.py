"""The server's methods: their parameters (checked before anything is queued) and what they do.

Each :class:`Method` lists its :class:`Param` s in order (so positional arrays and the
Twig line protocol map onto them) and a function ``fn(server, session, **params)``
that runs on the simulation's own loop, between steps. Checks that need the world
(does this entity exist? is it a character?) happen there, when the command is applied.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

from twig_ecs.arguments import ArgumentError, Param, check_plain
from twig_ecs.arguments import bind as bind_arguments
from twig_ecs.character import START_COMMANDS, CharacterHandle
from twig_ecs.goals import GoalSchema
from twig_ecs.plugins import builtin_goal_schemas
from twig_ecs.server.protocol import BROKEN_WORLD, INVALID_PARAMS, NOT_NOW, RPCError
from twig_ecs.spawn import crowding


class Server(Protocol):
    """What the methods use of the server (:class:`twig_ecs.server.core.Server`)."""

    scene: Any
    paused: bool
    autonomous: bool
    sessions: Any
    goal_owners: dict[int, Any]

    @property
    def world_status(self) -> Any: ...

    def set_paused(self, paused: bool) -> None: ...
    def remove_entity(self, name: str) -> None: ...
    async def step_frames(self, n: int) -> None: ...


class Session(Protocol):
    """What the methods use of a client's session (:class:`twig_ecs.server.session.Session`)."""

    authenticated: bool
    subscriptions: Any


#: Most frames one ``step`` call may run (60 s of simulated time).
MAX_STEP = 3600
#: Bodies beyond which ``spawn`` is refused: the steps (and so every answer) stay quick.
MAX_SERVED_BODIES = 2000
#: Most bodies that may already reach into the box a spawned body would fill: a spawn into a
#: pile is refused (1000 humanoids at one spot step at under 1 frame/s; four are a scuffle).
MAX_CROWD = 4
#: Event kinds a client can subscribe to.
EVENT_KINDS = ("goal.done", "goal.failed", "behavior.changed", "pain", "contact", "grab", "release")


@dataclass(frozen=True, slots=True)
class Method:
    """A callable method: ``subject`` is the parameter the Twig line's object name fills."""

    name: str
    params: tuple[Param, ...]
    fn: Callable[..., Any]
    doc: str
    subject: str | None = None
    queued: bool = True  # False: answered at once, without touching the world


def _bad(message: str) -> RPCError:
    return RPCError(INVALID_PARAMS, message)


def bind(method: Method, params: dict[str, Any] | list[Any]) -> dict[str, Any]:
    """Check ``params`` (by name or by position) against ``method``; returns keyword arguments."""
    try:
        return bind_arguments(method.name, method.params, params)
    except ArgumentError as exc:
        raise _bad(str(exc)) from None


# -- reading the world ------------------------------------------------------------------------


def _vec(v: Any) -> list[float]:
    return [float(x) for x in v]


def _entity(server: Server, name: str):
    try:
        return server.scene.entity(name)
    except KeyError as exc:
        raise _bad(str(exc.args[0])) from None


def _character(server: Server, name: str) -> CharacterHandle:
    handle = _entity(server, name)
    if not isinstance(handle, CharacterHandle):
        raise _bad(f"'{name}' is not a character (it is a {handle.template})")
    return handle


def entity_state(handle) -> dict[str, Any]:
    """What ``get_state`` reports for one entity."""
    out: dict[str, Any] = {
        "name": handle.name,
        "template": handle.template,
        "character": isinstance(handle, CharacterHandle),
        "position": _vec(handle.position),
        "velocity": _vec(handle.velocity),
        "pain": float(handle.pain),
    }
    if isinstance(handle, CharacterHandle):
        gaze = handle.gaze_target
        out.update(
            facing=_vec(handle.facing),
            posture=handle.posture,
            behaviour=handle.behaviour,
            autonomous=handle.autonomous,
            holding=handle.holding,
            walk_velocity=_vec(handle.walk_velocity),
            gaze_target=None if gaze is None else _vec(gaze),
            goals=[{"goal": g.id, "behavior": g.behavior, "status": g.status} for g in handle.goals],
        )
    return out


# -- the methods ---------------------------------------------------------------------------------


def _non_finite(state: dict[str, Any]) -> list[str]:
    """The fields of an entity's state that hold NaN or infinity (a body whose simulation broke down)."""
    bad = []
    for key, value in state.items():
        values = value if isinstance(value, list) else [value]
        if any(isinstance(v, float) and not math.isfinite(v) for v in values):
            bad.append(key)
    return bad


def _broken(names: dict[str, list[str]]) -> RPCError:
    """The error for entities with non-finite states: which, and what to do."""
    shown = "; ".join(f"'{n}' ({', '.join(fields)})" for n, fields in list(names.items())[:5])
    more = f" and {len(names) - 5} more" if len(names) > 5 else ""
    return RPCError(BROKEN_WORLD, f"the world has non-finite positions (NaN or infinity): {shown}{more}; "
                                  "their simulation broke down - remove them, or restart the server "
                                  "(twig validate the scene's templates)")  # fmt: skip


def list_entities(server: Server, session: Session) -> list[dict[str, Any]]:
    scene = server.scene
    out = []
    for name in scene.entity_names:
        h = scene.entity(name)
        out.append({"name": name, "template": h.template, "character": isinstance(h, CharacterHandle)})
    return out


def get_state(server: Server, session: Session, name: str | None) -> dict[str, Any]:
    """One entity's state, or every entity's; error BROKEN_WORLD naming those holding NaN."""
    scene = server.scene
    names = [name] if name is not None else scene.entity_names
    states = {n: entity_state(_entity(server, n)) for n in names}
    broken = {n: fields for n, state in states.items() if (fields := _non_finite(state))}
    if broken:
        raise _broken(broken)
    if name is not None:
        return states[name]
    return {"frame": scene.frame, "time": scene.time, "paused": server.paused, "entities": states}


def status(server: Server, session: Session) -> dict[str, Any]:
    """Answered at once: the world as of the end of the last step or command (never waits for one)."""
    world = server.world_status
    return {
        "scene": world["scene"],
        "frame": world["frame"],
        "time": world["time"],
        "paused": server.paused,
        "state_hash": world["state_hash"],
        "clients": len(server.sessions),
        "subscriptions": sorted(session.subscriptions),
    }


def _goal(server: Server, session: Session, character: str, behavior: str, params: dict) -> dict[str, Any]:
    handle = _character(server, character)
    if "on_end" in params:  # do()'s callback argument, never a goal parameter from a client
        raise _bad(f"{behavior}: unknown parameter 'on_end'")
    goal = handle.do(behavior, **params)
    server.goal_owners[goal.id] = session
    return {"goal": goal.id, "character": character, "behavior": behavior}


def _goal_method(behavior: str):
    def run(server: Server, session: Session, character: str, **params) -> dict[str, Any]:
        return _goal(server, session, character, behavior, params)

    return run


def goal_do(server: Server, session: Session, character: str, behavior: str, params: Any):
    if params is not None and not isinstance(params, dict):
        raise _bad("'params' must be an object")
    try:
        check_plain(params, "params")
    except ArgumentError as exc:
        raise _bad(str(exc)) from None
    return _goal(server, session, character, behavior, params or {})


def goal_schemas(server: Server, session: Session) -> list[dict[str, Any]]:
    """The schemas of every goal behaviour of the served scene, plug-ins included."""
    behaviors = server.scene.behaviors.values()
    return [b.schema.describe() for b in behaviors if b.goal_driven and b.schema is not None]


def walk(server: Server, session: Session, character: str, velocity) -> None:
    _character(server, character).walk(velocity)


def stop(server: Server, session: Session, character: str) -> None:
    _character(server, character).stop()


def look_at(server: Server, session: Session, character: str, target) -> None:
    _character(server, character).look_at(target)


def reach(server: Server, session: Session, character: str, target, hand: str) -> None:
    _character(server, character).reach(target, hand=hand)


def grab(server: Server, session: Session, character: str, target: str, hand: str) -> None:
    _character(server, character).grab(target, hand=hand)


def release(server: Server, session: Session, character: str, hand: str | None) -> None:
    _character(server, character).release(hand)


def cancel_goals(server: Server, session: Session, character: str) -> None:
    _character(server, character).cancel_goals()


def set_autonomous(server: Server, session: Session, character: str, autonomous: bool) -> None:
    _character(server, character).autonomous = autonomous


def spawn(
    server: Server, session: Session, name: str | None, template: str, position, facing: float, **extra
) -> dict[str, Any]:
    params = {k: v for k, v in extra.items() if v is not None}
    scene = server.scene
    _check_character(params.get("character"))
    bodies = scene.state.bodies.count
    if bodies >= MAX_SERVED_BODIES:
        message = (f"spawn refused: the scene has {bodies} bodies and a server spawns up to "
                   f"{MAX_SERVED_BODIES} (more would slow every step); remove some first")  # fmt: skip
        raise RPCError(NOT_NOW, message)
    body = scene.library.template(template)  # KeyError (with suggestions) if unknown
    scale = float(params.get("height") or body.height) / body.reference_height
    crowd = crowding(scene, body, scale, position, facing)
    if len(crowd) >= MAX_CROWD:
        names = [scene.name_of(int(scene.state.bodies.entity[b])) or str(b) for b in crowd]
        message = (f"spawn refused: at {_point(position)} the new body would overlap {len(crowd)} bodies "
                   f"({_listed(names, 5)}); at most {MAX_CROWD - 1} may reach into its space (MAX_CROWD: "
                   f"a pile makes every step slow) - spawn it somewhere free")  # fmt: skip
        raise RPCError(NOT_NOW, message)
    handle = scene.spawn(template, name=name, position=position, facing=facing, **params)
    if isinstance(handle, CharacterHandle) and not server.autonomous:
        handle.autonomous = False
    return {"name": handle.name}


def _point(position) -> str:
    return "[" + ", ".join(f"{float(x):g}" for x in position) + "]"


def _check_character(character: Any) -> None:
    """``character`` of a spawn: true/false, or a mapping of its settings (``max_speed``) only.

    A scene file's starting commands (walk, look_at...) are refused, not ignored: over the
    server they are methods of their own, called once the body is there.
    """
    if not isinstance(character, dict):
        return  # true / false / null: the spawn's own checks
    extra = [k for k in character if k != "max_speed"]
    if not extra:
        return
    commands = [k for k in extra if k in START_COMMANDS]
    unknown = [k for k in extra if k not in START_COMMANDS]
    parts = []
    if unknown:
        parts.append(f"unknown key(s) {_listed(unknown)}")
    if commands:
        parts.append(f"{_listed(commands)}: starting commands of scene files, which spawn does not run - "
                     "spawn the body, then call the methods (walk, look_at, reach, gesture, grab, sit) "
                     "with its name")  # fmt: skip
    raise _bad(f"spawn: character {'; '.join(parts)} (here character may hold only 'max_speed')")


def _listed(names: list[str], most: int = 8) -> str:
    """Names quoted and shortened, the first ``most`` of them: an error message stays short."""
    more = f" and {len(names) - most} more" if len(names) > most else ""
    return ", ".join(f"'{n[:40]}'" for n in names[:most]) + more


def remove(server: Server, session: Session, name: str) -> None:
    server.remove_entity(_entity(server, name).name)


def pause(server: Server, session: Session) -> dict[str, Any]:
    server.set_paused(True)
    return {"frame": server.scene.frame, "time": server.scene.time}


def resume(server: Server, session: Session) -> dict[str, Any]:
    server.set_paused(False)
    return {"frame": server.scene.frame, "time": server.scene.time}


async def step(server: Server, session: Session, n: int) -> dict[str, Any]:
    if not server.paused:
        raise RPCError(NOT_NOW, "step runs only while paused: call pause first")
    await server.step_frames(n)
    scene = server.scene
    return {"frame": scene.frame, "time": scene.time, "state_hash": scene.state_hash()}


def subscribe(server: Server, session: Session, events: list[str]) -> dict[str, Any]:
    session.subscriptions.update(events)
    return {"subscribed": sorted(session.subscriptions)}


def unsubscribe(server: Server, session: Session, events: list[str]) -> dict[str, Any]:
    session.subscriptions.difference_update(events)
    return {"subscribed": sorted(session.subscriptions)}


def ping(server: Server, session: Session) -> str:
    return "pong"


def auth(server: Server, session: Session, token: str) -> dict[str, Any]:
    return {"authenticated": session.authenticated}  # the session checks the token itself


_WHO = Param("character", "name")
_TARGET = Param("target", "name")
_HAND = Param("hand", "choice", "right", choices=("left", "right"))


def goal_method(schema: GoalSchema) -> Method:
    """The RPC method of a goal: ``character`` and then the schema's parameters, in order."""
    return Method(schema.name, (_WHO, *schema.params), _goal_method(schema.name), "Goal: " + schema.doc,
                  subject="character")  # fmt: skip


_ALL = (
    Method("ping", (), ping, "Answer 'pong' (a liveness check).", queued=False),
    Method(
        "auth",
        (Param("token", "str"),),
        auth,
        "Send the server's token (first, when it has one).",
        queued=False,
    ),
    Method(
        "subscribe",
        (Param("events", "kinds", choices=EVENT_KINDS),),
        subscribe,
        "Receive notifications of these event kinds ('*' for all).",
        queued=False,
    ),
    Method(
        "unsubscribe",
        (Param("events", "kinds", choices=EVENT_KINDS),),
        unsubscribe,
        "Stop receiving these event kinds.",
        queued=False,
    ),
    Method("status", (), status, "Scene name, frame, time, paused, state hash, clients.", queued=False),
    Method("list_entities", (), list_entities, "Every entity: name, template, character or not."),
    Method(
        "get_state",
        (Param("name", "name", None),),
        get_state,
        "One entity's state, or (no name) every entity's with the frame and time.",
        subject="name",
    ),
    *(goal_method(schema) for schema in builtin_goal_schemas()),
    Method(
        "do",
        (_WHO, Param("behavior", "str"), Param("params", "object", None)),
        goal_do,
        "Goal of any goal behaviour by name (plug-ins too), with its parameters.",
        subject="character",
    ),
    Method(
        "goal_schemas",
        (),
        goal_schemas,
        "Every goal of the scene (plug-ins too): name, doc, parameters with kinds and defaults.",
    ),
    Method(
        "cancel_goals",
        (_WHO,),
        cancel_goals,
        "Fail every queued goal of a character ('cancelled').",
        subject="character",
    ),
    Method(
        "walk",
        (_WHO, Param("velocity", "vector")),
        walk,
        "Walk at a ground velocity (m/s) until stopped.",
        subject="character",
    ),
    Method("stop", (_WHO,), stop, "Stand still.", subject="character"),
    Method(
        "look_at",
        (_WHO, Param("target", "target", None)),
        look_at,
        "Look at an entity or point (null: where it goes).",
        subject="character",
    ),
    Method(
        "reach",
        (
            _WHO,
            Param("target", "target"),
            Param("hand", "choice", "right", choices=("left", "right", "both")),
        ),
        reach,
        "Reach a hand to an entity or point.",
        subject="character",
    ),
    Method(
        "grab", (_WHO, _TARGET, _HAND), grab, "Grab a thing within reach of the hand.", subject="character"
    ),
    Method(
        "release",
        (_WHO, Param("hand", "choice", None, choices=("left", "right"))),
        release,
        "Let go with one hand, or both (no hand).",
        subject="character",
    ),
    Method(
        "set_autonomous",
        (_WHO, Param("autonomous", "bool")),
        set_autonomous,
        "true: it acts on its own; false: only goals and reflexes move it.",
        subject="character",
    ),
    Method(
        "spawn",
        (
            Param("name", "name", None),
            Param("template", "str"),
            Param("position", "vector", (0.0, 0.0, 0.0)),
            Param("facing", "number", 0.0, low=-3600.0, high=3600.0),
            Param("height", "number", None, low=0.01, high=100.0),
            Param("mass", "number", None, low=1e-3, high=1e6),
            Param("color", "color", None),
            Param("character", "object", None),
            Param("pain", "object", None),
            Param("damping", "object", None),
        ),
        spawn,
        "Spawn a body from a template; returns its name.",
        subject="name",
    ),
    Method(
        "remove",
        (Param("name", "name"),),
        remove,
        "Remove an entity (goals naming it fail first).",
        subject="name",
    ),
    Method("pause", (), pause, "Stop the real-time clock (step then advances it)."),
    Method("resume", (), resume, "Run at 60 Hz in real time again."),
    Method(
        "step",
        (Param("n", "int", 1, low=1, high=MAX_STEP),),
        step,
        "While paused: advance n frames; returns frame, time, state_hash.",
    ),
)

#: Methods by name.
METHODS: dict[str, Method] = {m.name: m for m in _ALL}


def find_method(name: str, scene: Any = None) -> Method | None:
    """The method called ``name``: one of :data:`METHODS`, or the goal method of a plug-in goal
    behaviour of ``scene`` (made from its schema, like the built-in goals' methods)."""
    method = METHODS.get(name)
    if method is not None or scene is None:
        return method
    behavior = scene.behaviors.get(name)
    if behavior is None or not behavior.goal_driven or behavior.schema is None:
        return None
    return goal_method(behavior.schema)
