"""Goal schemas: a goal behaviour's name, parameters and docs, written once.

A goal behaviour (``systems/behaviours/hug.py``, a plug-in's) declares a :class:`GoalSchema`. From
it come everything a command to that goal needs, so none of it is written twice:

- the ``CharacterHandle`` method (``ann.drag("doll", speed=0.6)``), with a real
  signature and docstring (:meth:`GoalSchema.signature`, :meth:`GoalSchema.docstring`);
- the checks of a goal's parameters, from Python and from ``do`` (:meth:`GoalSchema.bind`,
  through :func:`twig_ecs.arguments.check_value`);
- the server's RPC method of the same name and its validation, and the Twig line
  command (``twig_ecs.server.methods``);
- the tables in docs/characters.md and docs/server.md (``python -m twig_ecs.goaldocs``).

This module is core: it imports only :mod:`twig_ecs.arguments`.
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass
from typing import Any

from twig_ecs.arguments import ArgumentError, Param, bind

#: Parameter kinds a goal may take (the others - kinds, object, color - are for server methods).
GOAL_KINDS = ("name", "target", "vector", "number", "bool", "choice", "str", "int")
#: How each kind reads in a Python signature.
_ANNOTATIONS = {
    "name": "str",
    "str": "str",
    "target": "str | Sequence[float]",
    "vector": "Sequence[float]",
    "number": "float",
    "int": "int",
    "bool": "bool",
    "choice": "str",
}


def seconds(name: str, default: Any, doc: str) -> Param:
    """A duration parameter: seconds, 0 to 3600."""
    return Param(name, "number", default, low=0.0, high=3600.0, unit="s", doc=doc)


def metres(name: str, default: Any, doc: str) -> Param:
    """A distance parameter: metres, 0 to 1000."""
    return Param(name, "number", default, low=0.0, high=1000.0, unit="m", doc=doc)


def speed(name: str, default: Any, doc: str) -> Param:
    """A walking speed: m/s, 0.1 to 100; a goal is refused a speed above its character's ``max_speed``."""
    return Param(name, "number", default, low=0.1, high=100.0, unit="m/s", doc=doc)


@dataclass(frozen=True)
class GoalSchema:
    """One goal: its name, a one-line summary and its ordered parameters.

    ``handle_method``: whether ``CharacterHandle`` gets a method of the goal's name. The
    goals ``sit``, ``stand`` and ``gesture`` share their names with the handle's immediate
    controls (which set targets at once, without a goal), so those goals are reached with
    ``handle.do("sit", on="bench")`` (and over RPC by their own methods).
    """

    name: str
    doc: str
    params: tuple[Param, ...] = ()
    handle_method: bool = True

    def __post_init__(self) -> None:
        names = [p.name for p in self.params]
        if len(set(names)) != len(names):
            raise ValueError(f"goal '{self.name}' lists a parameter twice: {names}")
        for p in self.params:
            if p.kind not in GOAL_KINDS:
                raise ValueError(f"goal '{self.name}': parameter '{p.name}' has kind '{p.kind}'; "
                                 f"a goal parameter is one of {', '.join(GOAL_KINDS)}")  # fmt: skip
            if p.name == "on_end":
                raise ValueError(f"goal '{self.name}': 'on_end' is the handle's callback, not a parameter")

    @property
    def defaults(self) -> dict[str, Any]:
        """The optional parameters' defaults, in order."""
        return {p.name: p.default for p in self.params if not p.required}

    def bind(self, given: dict[str, Any]) -> dict[str, Any]:
        """Every parameter of a goal, checked and converted, defaults filled (in schema order).

        Raises :class:`~twig_ecs.arguments.ArgumentError` starting with the goal's name.
        """
        try:
            return bind(self.name, self.params, given)
        except ArgumentError as exc:
            message = str(exc)
            named = message if message.startswith(f"{self.name}:") else f"{self.name}: {message}"
            raise ArgumentError(named) from None

    def signature(self) -> inspect.Signature:
        """The handle method's signature: ``(self, <params in order>, *, on_end=None)``."""
        params = [inspect.Parameter("self", inspect.Parameter.POSITIONAL_OR_KEYWORD)]
        for p in self.params:
            default = inspect.Parameter.empty if p.required else p.default
            annotation = _ANNOTATIONS[p.kind] + (" | None" if p.default is None or p.nullable else "")
            params.append(inspect.Parameter(p.name, inspect.Parameter.POSITIONAL_OR_KEYWORD,
                                            default=default, annotation=annotation))  # fmt: skip
        params.append(inspect.Parameter("on_end", inspect.Parameter.KEYWORD_ONLY, default=None,
                                        annotation="Callable[[Goal], None] | None"))  # fmt: skip
        return inspect.Signature(params, return_annotation="Goal")

    def docstring(self) -> str:
        """The handle method's docstring: the summary, then one line per parameter."""
        lines = [self.doc, ""]
        for p in self.params:
            default = "required" if p.required else f"default {p.default!r}"
            lines.append(f"``{p.name}``: {p.doc} - {p.describe()}; {default}.")
        lines += ["", "Queues the goal and returns it (a Goal); its end is a ``goal.done`` or",
                  "``goal.failed`` event, and ``on_end(goal)`` is called if given."]  # fmt: skip
        return "\n".join(lines)

    def handle_function(self):
        """A function to put on ``CharacterHandle``: checks the call, then ``self.do(name, ...)``.

        Only the arguments the caller gave are passed on (the scene's own behaviour fills
        the rest from its schema), so the method stays right if a scene's plug-in differs.
        """
        signature = self.signature()
        goal = self.name

        def method(self, *args, on_end=None, **kwargs):
            bound = signature.bind(self, *args, on_end=on_end, **kwargs)  # TypeError like any call
            given = {k: v for k, v in bound.arguments.items() if k not in ("self", "on_end")}
            return self.do(goal, on_end=on_end, **given)

        method.__name__ = method.__qualname__ = goal
        method.__doc__ = self.docstring()
        method.__signature__ = signature
        method.goal_schema = self  # marks it as derived (a plug-in may replace it, never a control)
        return method

    def describe(self) -> dict[str, Any]:
        """The schema as JSON-ready data (the server's ``goal_schemas`` answer)."""
        return {
            "name": self.name,
            "doc": self.doc,
            "params": [
                {
                    "name": p.name,
                    "kind": p.kind,
                    "required": p.required,
                    "default": None if p.required else _plain(p.default),
                    **({"choices": list(p.choices)} if p.kind == "choice" else {}),
                    **({"low": p.low, "high": p.high} if p.kind == "number" else {}),
                    **({"unit": p.unit} if p.unit else {}),
                    "doc": p.doc,
                }
                for p in self.params
            ],
        }


def _plain(value: Any) -> Any:
    return list(value) if isinstance(value, tuple) else value
