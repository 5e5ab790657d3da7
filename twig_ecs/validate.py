"""Small typed readers for YAML documents that fail with file:line and a path.

Each reader takes the containing mapping or list, the key or index, and the path of
that value inside the document (``entities[2].body``), and either returns a clean
Python value or raises :class:`~twig_ecs.errors.SceneError` naming what was expected.
"""

from __future__ import annotations

import difflib
import math
import numbers
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from typing import Any, NoReturn

from twig_ecs.errors import SceneError
from twig_ecs.yamldoc import YDict, YList

MISSING: Any = object()


def fail(container: Any, key: Any, path: str, message: str) -> NoReturn:
    """Raise a SceneError located at ``container[key]``."""
    if isinstance(container, (YDict, YList)):
        file, line = container.where(key)
    else:
        file, line = None, None
    raise SceneError(message, file, line, path)


class SceneErrors(SceneError):
    """Several independent mistakes in one file (one entity each, or the settings), all told."""

    def __init__(self, errors: list[SceneError]) -> None:
        first = errors[0]
        super().__init__(first.message, first.file, first.line, first.path)
        self.errors = errors
        self.args = ("\n".join(str(e) for e in errors),)

    def __str__(self) -> str:
        return self.args[0]


@contextmanager
def gather(errors: list[SceneError]) -> Iterator[None]:
    """Run one independent part of a document, noting a SceneError in ``errors`` instead of
    stopping, so the next part is checked too; :func:`raise_all` reports them together."""
    try:
        yield
    except SceneErrors as exc:
        errors.extend(exc.errors)
    except SceneError as exc:
        errors.append(exc)


def raise_all(errors: list[SceneError]) -> None:
    """Raise the gathered errors: the one error itself, or a :class:`SceneErrors` of all."""
    if len(errors) == 1:
        raise errors[0]
    if errors:
        raise SceneErrors(errors)


def suggest(name: str, known: Iterable[str]) -> str:
    """' (did you mean 'x'?)' or ' (known: a, b, c)' for an unknown name."""
    known = sorted(known)
    close = difflib.get_close_matches(name, known, n=1)
    if close:
        return f" (did you mean '{close[0]}'?)"
    return f" (known: {', '.join(known)})" if known else ""


def join(path: str, key: Any) -> str:
    """Extend a document path by a mapping key or a list index."""
    if isinstance(key, int):
        return f"{path}[{key}]"
    return f"{path}.{key}" if path else str(key)


#: What a value read from YAML is called in messages (the reader's own classes are not the user's words).
_KIND_NAMES = {"YDict": "mapping", "YList": "list", "dict": "mapping", "str": "text", "NoneType": "nothing",
               "bool": "true/false", "int": "whole number", "float": "number"}  # fmt: skip


def _describe(value: Any) -> str:
    text = repr(value)
    if len(text) > 40:
        text = text[:37] + "..."
    kind = type(value).__name__
    return f"{text} ({_KIND_NAMES.get(kind, kind)})"


# -- value kinds: each takes a raw value, returns the clean one or raises ValueError(expected)


#: Largest magnitude any number in a scene may have: a million metres, kilograms or
#: seconds is far beyond any sensible scene, and keeps float64 positions precise.
LIMIT = 1e6


def number(value: Any) -> float:
    """A finite real number (not a boolean) of magnitude at most LIMIT."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError("a finite number")
    # a whole number is compared before it becomes a float: past 1e308 it cannot
    if not isinstance(value, int) and not math.isfinite(value):
        raise ValueError("a finite number")
    if abs(value) > LIMIT:
        raise ValueError(f"a number between -{LIMIT:g} and {LIMIT:g}")
    return float(value)


def _bounded(value: Any, ok, expected: str) -> float:
    try:
        x = number(value)
    except ValueError:
        raise ValueError(f"{expected} (and at most {LIMIT:g} in size)") from None
    if not ok(x):
        raise ValueError(expected)
    return x


def positive(value: Any) -> float:
    """A number > 0."""
    return _bounded(value, lambda x: x > 0, "a number greater than 0")


def nonnegative(value: Any) -> float:
    """A number >= 0."""
    return _bounded(value, lambda x: x >= 0, "a number of at least 0")


def between(lo: float, hi: float) -> Callable[[Any], float]:
    """A number in [lo, hi] (a body's height or mass: a tiny one divides by zero when spawned)."""

    def read(value: Any) -> float:
        return _bounded(value, lambda x: lo <= x <= hi, f"a number from {lo:g} to {hi:g}")

    return read


def fraction(value: Any) -> float:
    """A number in [0, 1]."""
    return _bounded(value, lambda x: 0 <= x <= 1, "a number from 0 to 1")


def integer(lo: int, hi: int) -> Callable[[Any], int]:
    """An integer in [lo, hi]."""

    def read(value: Any) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
            raise ValueError(f"a whole number from {lo} to {hi}")
        return value

    return read


#: Largest random seed: numpy's generators take any whole number >= 0; this one fits 64 bits.
MAX_SEED = 2**63 - 1


def seed(value: Any) -> int:
    """A random seed: a whole number from 0 to :data:`MAX_SEED`."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or not 0 <= value <= MAX_SEED:
        raise ValueError(f"a seed is a whole number from 0 to {MAX_SEED}")
    return int(value)


def text(value: Any) -> str:
    """A non-empty string of valid Unicode (no lone surrogate, which cannot be written out)."""
    if not isinstance(value, str) or not value.strip():
        raise ValueError("a non-empty string")
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise ValueError("valid Unicode text (it holds a lone surrogate such as \\ud800)") from None
    return value


def boolean(value: Any) -> bool:
    """true or false."""
    if not isinstance(value, bool):
        raise ValueError("true or false")
    return value


def vec3(value: Any) -> tuple[float, float, float]:
    """A list of three numbers [x, y, z]."""
    if not isinstance(value, list) or len(value) != 3:
        raise ValueError("a list of three numbers [x, y, z]")
    return tuple(number(v) for v in value)  # type: ignore[return-value]


def color(value: Any) -> tuple[float, float, float, float]:
    """An RGB(A) colour: [r, g, b] or [r, g, b, a] in 0..1, or '#rrggbb'."""
    if isinstance(value, str) and len(value) == 7 and value.startswith("#"):
        try:
            return tuple(int(value[i : i + 2], 16) / 255 for i in (1, 3, 5)) + (1.0,)  # type: ignore[return-value]
        except ValueError:
            pass
    if isinstance(value, list) and len(value) in (3, 4):
        try:
            rgba = [fraction(v) for v in value]
        except ValueError:
            pass
        else:
            return tuple(rgba + [1.0] * (4 - len(rgba)))  # type: ignore[return-value]
    raise ValueError("a colour: [r, g, b] with numbers from 0 to 1, or '#rrggbb'")


def mapping(value: Any) -> YDict:
    """A mapping (key: value lines)."""
    if not isinstance(value, dict):
        raise ValueError("a mapping of keys to values")
    return value  # type: ignore[return-value]


def sequence(value: Any) -> YList:
    """A list."""
    if not isinstance(value, list):
        raise ValueError("a list")
    return value  # type: ignore[return-value]


def names(count: int) -> Callable[[Any], tuple[str, ...]]:
    """A list of exactly ``count`` names."""

    def read(value: Any) -> tuple[str, ...]:
        if not isinstance(value, list) or len(value) != count:
            raise ValueError(f"a list of {count} node names")
        return tuple(text(v) for v in value)

    return read


# -- readers that know where they are


def read(container: Any, key: Any, path: str, kind: Callable[[Any], Any], default: Any = MISSING) -> Any:
    """Read ``container[key]`` as ``kind``; a missing key takes ``default`` or fails."""
    here = join(path, key)
    if isinstance(container, dict):
        present = key in container
    else:
        present = 0 <= key < len(container)
    if not present:
        if default is MISSING:
            fail(container, None, here, "missing required key")
        return default
    value = container[key]
    try:
        return kind(value)
    except ValueError as exc:
        fail(container, key, here, f"expected {exc}, got {_describe(value)}")


def check_keys(doc: YDict, path: str, allowed: Iterable[str], what: str = "key") -> None:
    """Fail on every key of ``doc`` that is not ``allowed`` (each with its line, all at once)."""
    allowed = list(allowed)
    errors: list[SceneError] = []
    for key in doc:
        if key not in allowed:
            with gather(errors):
                fail(doc, key, join(path, key), f"unknown {what} '{key}'" + suggest(str(key), allowed))
    raise_all(errors)
