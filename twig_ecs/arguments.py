"""Typed command arguments: one :class:`Param` notion and one validator for every entry point.

A :class:`Param` names an argument, its kind, its default (absent: required), its bounds
or choices and a line of docs. :func:`check_value` is the one place a value from a
Python call, a JSON-RPC request or a Twig line is checked and converted: goal schemas
(:mod:`twig_ecs.goals`), the server's methods and the line protocol all use it, so a
wrong value gets the same message wherever it came from. Failures raise
:class:`ArgumentError` (a :class:`~twig_ecs.errors.TwigError`); the server answers them
as JSON-RPC error -32602.

This module is core: it imports nothing above errors and validate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from twig_ecs.errors import TwigError
from twig_ecs.validate import LIMIT

REQUIRED: Any = object()
#: Deepest nesting of lists and objects inside a parameter.
MAX_NESTING = 16
#: Longest text a ``name`` or ``str`` argument may be.
MAX_TEXT = 200

#: What each kind accepts, in words (for docs and for help text).
KIND_WORDS = {
    "name": "an entity name",
    "str": "text",
    "number": "a number",
    "int": "a whole number",
    "bool": "true or false",
    "vector": "a point or vector [x, y, z] ([x, z] on the ground)",
    "target": "an entity name or a point [x, y, z]",
    "choice": "one of the choices",
    "kinds": "an event kind or a list of them",
    "object": "a JSON object, or a boolean",
    "color": "3 numbers [r, g, b] in [0, 1]",
}


class ArgumentError(TwigError):
    """A value that does not fit its parameter; the message says which and what it must be."""


@dataclass(frozen=True, slots=True)
class Param:
    """One parameter: its name, kind, default (absent: required), bounds and docs.

    Kinds (see :data:`KIND_WORDS`): ``name`` (an entity name), ``str``, ``number``, ``int``,
    ``bool``, ``vector`` (3 numbers, or 2 for a ground point [x, z]), ``target`` (an entity
    name or a vector), ``choice`` (one of ``choices``), ``kinds`` (a list of event kinds:
    of the ``choices``, or "*" for all), ``object`` (a JSON object, or a boolean), ``color``
    (3 numbers in [0, 1]). ``low`` and
    ``high`` bound numbers; ``unit`` names theirs for the docs (``s``, ``m``, ``m/s``).
    ``figure``: a ``name`` must be of an entity with a head (a character or a ragdoll) -
    checked against the world where the command is applied.
    """

    name: str
    kind: str
    default: Any = REQUIRED
    low: float = -LIMIT
    high: float = LIMIT
    choices: tuple = ()
    nullable: bool = False
    doc: str = ""
    unit: str = ""
    figure: bool = False

    @property
    def required(self) -> bool:
        """No default: a call must give it."""
        return self.default is REQUIRED

    def describe(self) -> str:
        """What a value must be, in words: ``a number in s (0 to 3600)``, ``one of left, right``."""
        if self.kind == "choice":
            return "one of " + ", ".join(map(str, self.choices))
        if self.kind in ("number", "int"):
            unit = f" in {self.unit}" if self.unit else ""
            bounded = self.low > -LIMIT or self.high < LIMIT
            return KIND_WORDS[self.kind] + unit + (f" ({self.low:g} to {self.high:g})" if bounded else "")
        if self.figure:
            return "the name of a character or ragdoll (an entity with a head)"
        return KIND_WORDS[self.kind]


def number(p: Param, value: Any, where: str) -> float:
    """``value`` as a finite float within ``p``'s bounds, or ArgumentError naming ``where``."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ArgumentError(f"{where} must be a number, got {show(value)}")
    try:
        value = float(value)
    except OverflowError:  # a whole number past 1e308
        value = math.inf if value > 0 else -math.inf
    if not math.isfinite(value):
        raise ArgumentError(f"{where} must be a finite number, got {show(value)}")
    if not p.low <= value <= p.high:
        raise ArgumentError(f"{where} must be between {p.low:g} and {p.high:g}, got {value:g}")
    return value


def show(value: Any) -> str:
    """A short, safe rendering of a value for an error message."""
    if isinstance(value, float) and not math.isfinite(value):
        return "NaN" if value != value else ("Infinity" if value > 0 else "-Infinity")
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 200:
        return f"a {len(str(abs(value)))}-digit number"
    try:
        text = repr(value) if not isinstance(value, str) else f"'{value}'"
    except RecursionError:  # a list nested hundreds deep
        return f"a deeply nested {type(value).__name__}"
    return text if len(text) <= 60 else text[:57] + "..."


def check_text(value: str, where: str) -> None:
    """Refuse text that cannot be written back as UTF-8 (a lone surrogate from a JSON escape)."""
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise ArgumentError(
            f"{where} is not valid Unicode text (it holds a lone surrogate such as \\ud800)"
        ) from None


def _vector(p: Param, value: Any) -> tuple[float, ...]:
    # numpy arrays count too: Python callers pass them (a position read off a handle)
    if hasattr(value, "tolist") and not isinstance(value, str | bytes):
        value = value.tolist()
    if not isinstance(value, list | tuple) or len(value) not in (2, 3):
        raise ArgumentError(
            f"'{p.name}' must be a list of 3 numbers [x, y, z] (or 2, [x, z]), got {show(value)}"
        )
    nums = [number(Param("", "number"), v, f"'{p.name}[{i}]'") for i, v in enumerate(value)]
    if len(nums) == 2:
        nums = [nums[0], 0.0, nums[1]]
    return tuple(nums)


def check_value(p: Param, value: Any) -> Any:
    """``value`` converted for parameter ``p``, or ArgumentError naming the problem."""
    where = f"'{p.name}'"
    if value is None:
        if p.nullable or p.default is None:
            return None
        raise ArgumentError(f"{where} must not be null")
    kind = p.kind
    if kind in ("name", "str"):
        if not isinstance(value, str) or not value:
            raise ArgumentError(f"{where} must be a non-empty string, got {show(value)}")
        if len(value) > MAX_TEXT:
            raise ArgumentError(f"{where} is too long ({len(value)} characters; at most {MAX_TEXT})")
        check_text(value, where)
        return value
    if kind == "number":
        return number(p, value, where)
    if kind == "int":
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        if isinstance(value, bool) or not isinstance(value, int):
            raise ArgumentError(f"{where} must be a whole number, got {show(value)}")
        if not p.low <= value <= p.high:
            raise ArgumentError(f"{where} must be between {p.low:g} and {p.high:g}, got {value}")
        return value
    if kind == "bool":
        if not isinstance(value, bool):
            raise ArgumentError(f"{where} must be true or false, got {show(value)}")
        return value
    if kind == "vector":
        return _vector(p, value)
    if kind == "target":
        if isinstance(value, str):
            return check_value(Param(p.name, "name"), value)
        if isinstance(value, list | tuple) or hasattr(value, "tolist"):
            return _vector(p, value)
        raise ArgumentError(f"{where} must be an entity name or a point [x, y, z], got {show(value)}")
    if kind == "choice":
        if value not in p.choices:
            raise ArgumentError(f"{where} must be one of {', '.join(map(str, p.choices))}; got {show(value)}")
        return value
    if kind == "kinds":  # event kinds: the known ones are the choices, "*" stands for all
        known = ", ".join(p.choices)
        items = [value] if isinstance(value, str) else value
        if not isinstance(items, list) or not items:
            raise ArgumentError(f"{where} must be an event kind or a list of them ({known})")
        for item in items:
            if item not in p.choices and item != "*":
                raise ArgumentError(f"{where}: unknown event kind {show(item)} (known: {known}, *)")
        return list(p.choices) if "*" in items else list(dict.fromkeys(items))
    if kind == "object":
        if not isinstance(value, dict | bool):
            raise ArgumentError(f"{where} must be an object or a boolean, got {show(value)}")
        check_plain(value, p.name)
        return value
    if kind == "color":
        if not isinstance(value, list) or len(value) != 3:
            raise ArgumentError(f"{where} must be 3 numbers [r, g, b] between 0 and 1, got {show(value)}")
        unit = Param("", "number", low=0.0, high=1.0)
        return [number(unit, v, f"'{p.name}[{i}]'") for i, v in enumerate(value)]
    raise AssertionError(f"unknown parameter kind {kind}")


def check_plain(value: Any, where: str, depth: int = 0) -> None:
    """Every number inside a JSON value finite and not huge, every text valid, nesting shallow."""
    if depth > MAX_NESTING:
        raise ArgumentError(f"'{where}' is nested more than {MAX_NESTING} deep")
    if isinstance(value, dict):
        for k, v in value.items():
            check_plain(v, f"{where}.{k}", depth + 1)
    elif isinstance(value, list):
        for i, v in enumerate(value):
            check_plain(v, f"{where}[{i}]", depth + 1)
    elif isinstance(value, float | int) and not isinstance(value, bool):
        number(Param("", "number"), value, f"'{where}'")
    elif isinstance(value, str):
        check_text(value, f"'{where}'")
    if isinstance(value, dict):
        for k in value:
            check_text(str(k), f"'{where}' key")


def bind(name: str, params: tuple[Param, ...], given: dict[str, Any] | list[Any]) -> dict[str, Any]:
    """Check ``given`` (by name or by position) against ``params``; every parameter, defaults filled.

    ``name`` (a method's or a goal's) starts the messages about unknown, missing or too
    many arguments.
    """
    if isinstance(given, list):
        if len(given) > len(params):
            raise ArgumentError(f"{name} takes at most {len(params)} parameter(s), got {len(given)}")
        given = {p.name: v for p, v in zip(params, given, strict=False)}
    known = {p.name for p in params}
    unknown = [k for k in given if k not in known]
    if unknown:
        takes = ", ".join(p.name for p in params) or "none"
        raise ArgumentError(f"{name}: unknown parameter(s) {', '.join(map(show, unknown))} (takes: {takes})")
    out = {}
    for p in params:
        if p.name in given:
            out[p.name] = check_value(p, given[p.name])
        elif p.required:
            raise ArgumentError(f"{name}: missing parameter '{p.name}'")
        else:
            out[p.name] = p.default
    return out
