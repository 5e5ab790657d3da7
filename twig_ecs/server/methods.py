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
from typing import TYPE_CHECKING, Any

from twig_ecs.character import CharacterHandle
from twig_ecs.server.protocol import INVALID_PARAMS, NOT_NOW, RPCError
from twig_ecs.validate import LIMIT

if TYPE_CHECKING:
    from twig_ecs.server.core import Server, Session

_REQUIRED = object()
#: Event kinds a client can subscribe to.
EVENT_KINDS = ("goal.done", "goal.failed", "behavior.changed", "pain", "contact", "grab", "release")
#: Most frames one ``step`` call may run (60 s of simulated time).
MAX_STEP = 3600
#: Bodies beyond which ``spawn`` is refused: the steps (and so every answer) stay quick.
MAX_SERVED_BODIES = 2000
#: Deepest nesting of lists and objects inside a parameter.
MAX_NESTING = 16
#: Longest duration (s) a goal may be given.
MAX_DURATION = 3600.0


@dataclass(frozen=True, slots=True)
class Param:
    """One parameter: its name, kind, default (absent: required) and bounds.

    Kinds: ``name`` (an entity name), ``str``, ``number``, ``int``, ``bool``, ``vector``
    (3 numbers, or 2 for a ground point [x, z]), ``target`` (an entity name or a
    vector), ``choice`` (one of ``choices``), ``kinds`` (a list of event kinds),
    ``object`` (a JSON object, or a boolean), ``color`` (3 numbers in [0, 1]).
    """

    name: str
    kind: str
    default: Any = _REQUIRED
    low: float = -LIMIT
    high: float = LIMIT
    choices: tuple = ()
    nullable: bool = False

    @property
    def required(self) -> bool:
        return self.default is _REQUIRED


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


def _number(p: Param, value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise _bad(f"{where} must be a number, got {_show(value)}")
    try:
        value = float(value)
    except OverflowError:  # a whole number past 1e308
        value = math.inf if value > 0 else -math.inf
    if not math.isfinite(value):
        raise _bad(f"{where} must be a finite number, got {_show(value)}")
    if not p.low <= value <= p.high:
        raise _bad(f"{where} must be between {p.low:g} and {p.high:g}, got {value:g}")
    return value


def _show(value: Any) -> str:
    if isinstance(value, float) and not math.isfinite(value):
        return "NaN" if value != value else ("Infinity" if value > 0 else "-Infinity")
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 200:
        return f"a {len(str(abs(value)))}-digit number"
    try:
        text = repr(value) if not isinstance(value, str) else f"'{value}'"
    except RecursionError:  # a list nested hundreds deep
        return f"a deeply nested {type(value).__name__}"
    return text if len(text) <= 60 else text[:57] + "..."


def _check_text(value: str, where: str) -> None:
    """Refuse text that cannot be written back as UTF-8 (a lone surrogate from a JSON escape)."""
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise _bad(f"{where} is not valid Unicode text (it holds a lone surrogate such as \\ud800)") from None


def _vector(p: Param, value: Any) -> tuple[float, ...]:
    if not isinstance(value, list | tuple) or len(value) not in (2, 3):
        raise _bad(f"'{p.name}' must be a list of 3 numbers [x, y, z] (or 2, [x, z]), got {_show(value)}")
    nums = [_number(Param("", "number"), v, f"'{p.name}[{i}]'") for i, v in enumerate(value)]
    if len(nums) == 2:
        nums = [nums[0], 0.0, nums[1]]
    return tuple(nums)


def check_value(p: Param, value: Any) -> Any:
    """``value`` converted for parameter ``p``, or RPCError(-32602) naming the problem."""
    where = f"'{p.name}'"
    if value is None:
        if p.nullable or p.default is None:
            return None
        raise _bad(f"{where} must not be null")
    kind = p.kind
    if kind in ("name", "str"):
        if not isinstance(value, str) or not value:
            raise _bad(f"{where} must be a non-empty string, got {_show(value)}")
        if len(value) > 200:
            raise _bad(f"{where} is too long ({len(value)} characters; at most 200)")
        _check_text(value, where)
        return value
    if kind == "number":
        return _number(p, value, where)
    if kind == "int":
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        if isinstance(value, bool) or not isinstance(value, int):
            raise _bad(f"{where} must be a whole number, got {_show(value)}")
        if not p.low <= value <= p.high:
            raise _bad(f"{where} must be between {p.low:g} and {p.high:g}, got {value}")
        return value
    if kind == "bool":
        if not isinstance(value, bool):
            raise _bad(f"{where} must be true or false, got {_show(value)}")
        return value
    if kind == "vector":
        return _vector(p, value)
    if kind == "target":
        if isinstance(value, str):
            return check_value(Param(p.name, "name"), value)
        if isinstance(value, list | tuple):
            return _vector(p, value)
        raise _bad(f"{where} must be an entity name or a point [x, y, z], got {_show(value)}")
    if kind == "choice":
        if value not in p.choices:
            raise _bad(f"{where} must be one of {', '.join(map(str, p.choices))}; got {_show(value)}")
        return value
    if kind == "kinds":
        items = [value] if isinstance(value, str) else value
        if not isinstance(items, list) or not items:
            raise _bad(f"{where} must be an event kind or a list of them ({', '.join(EVENT_KINDS)})")
        for item in items:
            if item not in EVENT_KINDS and item != "*":
                raise _bad(f"{where}: unknown event kind {_show(item)} (known: {', '.join(EVENT_KINDS)}, *)")
        return list(EVENT_KINDS) if "*" in items else list(dict.fromkeys(items))
    if kind == "object":
        if not isinstance(value, dict | bool):
            raise _bad(f"{where} must be an object or a boolean, got {_show(value)}")
        _check_plain(value, p.name)
        return value
    if kind == "color":
        if not isinstance(value, list) or len(value) != 3:
            raise _bad(f"{where} must be 3 numbers [r, g, b] between 0 and 1, got {_show(value)}")
        unit = Param("", "number", low=0.0, high=1.0)
        return [_number(unit, v, f"'{p.name}[{i}]'") for i, v in enumerate(value)]
    raise AssertionError(f"unknown parameter kind {kind}")


def bind(method: Method, params: dict[str, Any] | list[Any]) -> dict[str, Any]:
    """Check ``params`` (by name or by position) against ``method``; returns keyword arguments."""
    if isinstance(params, list):
        if len(params) > len(method.params):
            raise _bad(f"{method.name} takes at most {len(method.params)} parameter(s), got {len(params)}")
        params = {p.name: v for p, v in zip(method.params, params, strict=False)}
    known = {p.name for p in method.params}
    unknown = [k for k in params if k not in known]
    if unknown:
        takes = ", ".join(p.name for p in method.params) or "none"
        raise _bad(f"{method.name}: unknown parameter(s) {', '.join(map(_show, unknown))} (takes: {takes})")
    out = {}
    for p in method.params:
        if p.name in params:
            out[p.name] = check_value(p, params[p.name])
        elif p.required:
            raise _bad(f"{method.name}: missing parameter '{p.name}'")
        else:
            out[p.name] = p.default
    return out


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


def list_entities(server: Server, session: Session) -> list[dict[str, Any]]:
    scene = server.scene
    out = []
    for name in scene.entity_names:
        h = scene.entity(name)
        out.append({"name": name, "template": h.template, "character": isinstance(h, CharacterHandle)})
    return out


def get_state(server: Server, session: Session, name: str | None) -> dict[str, Any]:
    scene = server.scene
    if name is not None:
        return entity_state(_entity(server, name))
    return {
        "frame": scene.frame,
        "time": scene.time,
        "paused": server.paused,
        "entities": {n: entity_state(scene.entity(n)) for n in scene.entity_names},
    }


def status(server: Server, session: Session) -> dict[str, Any]:
    scene = server.scene
    return {
        "scene": scene.name,
        "frame": scene.frame,
        "time": scene.time,
        "paused": server.paused,
        "state_hash": scene.state_hash(),
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


def _goal_method(behavior: str, param_names: tuple[str, ...]):
    def run(server: Server, session: Session, character: str, **params) -> dict[str, Any]:
        given = {k: params[k] for k in param_names}
        return _goal(server, session, character, behavior, given)

    return run


def gesture(server: Server, session: Session, character: str, name: str, target, duration: float):
    params = {"name": name, "target": target, "duration": duration}
    return _goal(server, session, character, "gesture", params)


def _check_plain(value: Any, where: str, depth: int = 0) -> None:
    """Every number inside a JSON value finite and not huge, every text valid, nesting shallow."""
    if depth > MAX_NESTING:
        raise _bad(f"'{where}' is nested more than {MAX_NESTING} deep")
    if isinstance(value, dict):
        for k, v in value.items():
            _check_plain(v, f"{where}.{k}", depth + 1)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            _check_plain(v, f"{where}[{i}]", depth + 1)
    elif isinstance(value, float | int) and not isinstance(value, bool):
        _number(Param("", "number"), value, f"'{where}'")
    elif isinstance(value, str):
        _check_text(value, f"'{where}'")
    if isinstance(value, dict):
        for k in value:
            _check_text(str(k), f"'{where}' key")


def goal_do(server: Server, session: Session, character: str, behavior: str, params: Any):
    if params is not None and not isinstance(params, dict):
        raise _bad("'params' must be an object")
    _check_plain(params, "params")
    return _goal(server, session, character, behavior, params or {})


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
    bodies = server.scene.state.bodies.count
    if bodies >= MAX_SERVED_BODIES:
        message = (f"spawn refused: the scene has {bodies} bodies and a server spawns up to "
                   f"{MAX_SERVED_BODIES} (more would slow every step); remove some first")  # fmt: skip
        raise RPCError(NOT_NOW, message)
    handle = server.scene.spawn(template, name=name, position=position, facing=facing, **params)
    if isinstance(handle, CharacterHandle) and not server.autonomous:
        handle.autonomous = False
    return {"name": handle.name}


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
_DURATION = Param("duration", "number", 2.0, low=0.0, high=MAX_DURATION)
_HAND = Param("hand", "choice", "right", choices=("left", "right"))

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
        (Param("events", "kinds"),),
        subscribe,
        "Receive notifications of these event kinds ('*' for all).",
        queued=False,
    ),
    Method(
        "unsubscribe",
        (Param("events", "kinds"),),
        unsubscribe,
        "Stop receiving these event kinds.",
        queued=False,
    ),
    Method("status", (), status, "Scene name, frame, time, paused, state hash, clients."),
    Method("list_entities", (), list_entities, "Every entity: name, template, character or not."),
    Method(
        "get_state",
        (Param("name", "name", None),),
        get_state,
        "One entity's state, or (no name) every entity's with the frame and time.",
        subject="name",
    ),
    Method(
        "approach",
        (
            _WHO,
            Param("target", "target"),
            Param("stop_distance", "number", 0.6, low=0.0, high=100.0),
            Param("direction", "vector", None),
            Param("arms", "choice", None, choices=("reach", "hug", "grapple")),
            Param("curl", "bool", True),
        ),
        _goal_method("approach", ("target", "stop_distance", "direction", "arms", "curl")),
        "Goal: walk to an entity or point, stopping stop_distance m off it.",
        subject="character",
    ),
    Method(
        "hug",
        (_WHO, _TARGET, _DURATION),
        _goal_method("hug", ("target", "duration")),
        "Goal: walk up to a character and hug it for duration s.",
        subject="character",
    ),
    Method(
        "grapple",
        (_WHO, _TARGET, Param("duration", "number", 3.0, low=0.0, high=MAX_DURATION)),
        _goal_method("grapple", ("target", "duration")),
        "Goal: close in and grapple a character for duration s.",
        subject="character",
    ),
    Method(
        "carry",
        (_WHO, _TARGET, Param("to", "target", None), _HAND),
        _goal_method("carry", ("target", "to", "hand")),
        "Goal: fetch a thing in one hand, then carry it to a point or entity.",
        subject="character",
    ),
    Method(
        "drag",
        (_WHO, _TARGET, Param("distance", "number", 5.0, low=0.0, high=1000.0), _HAND),
        _goal_method("drag", ("target", "distance", "hand")),
        "Goal: grab a body and walk distance m away pulling it.",
        subject="character",
    ),
    Method(
        "sit",
        (_WHO, Param("on", "name", None)),
        _goal_method("sit", ("on",)),
        "Goal: sit on the ground, or walk to a seat entity and sit on it.",
        subject="character",
    ),
    Method("stand", (_WHO,), _goal_method("stand", ()), "Goal: stand up.", subject="character"),
    Method(
        "freeze",
        (_WHO, Param("duration", "number", None, low=0.0, high=MAX_DURATION)),
        _goal_method("freeze", ("duration",)),
        "Goal: hold still for duration s (null: until the next goal).",
        subject="character",
    ),
    Method(
        "gesture",
        (
            _WHO,
            Param("name", "choice", choices=("wave", "point")),
            Param("target", "target", None),
            _DURATION,
        ),
        gesture,
        "Goal: wave, or point at a target, for duration s.",
        subject="character",
    ),
    Method(
        "do",
        (_WHO, Param("behavior", "str"), Param("params", "object", None)),
        goal_do,
        "Goal of any goal behaviour by name (plug-ins too), with its parameters.",
        subject="character",
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
