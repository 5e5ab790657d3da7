"""Scene parameters: ``parameters:`` in a scene file, set from Python or the command line.

A scene declares its parameters with defaults and bounds::

    parameters:
      count: {default: 100, min: 1, max: 5000, about: how many characters}

and uses them anywhere a value goes, as ``$count`` or as a small formula
``$(0.5 * spacing * sqrt(count))`` (numbers, parameters, + - * / // % **, and
sqrt, ceil, floor, round, min, max, abs). ``Scene.load("crowd", count=300)``,
``twig run crowd --count 300`` or ``--param count=300`` set them. A parameter is an
integer when its default is one, else a number; values outside the bounds, unknown
names and bad formulas are errors that say where.

A name with a dot is an **override** of any value in the file, declared or not
(``--set attachment.safe_distance=3``, ``Scene.load("schoolyard", **{"ball.damping.ground":
0.01})``): its first part names a behaviour (every ``use:`` of it), an entity, or
``settings``; the rest is the key path inside. The file is then validated as if it had
been written so (:func:`override`).
"""

from __future__ import annotations

import ast
import math
import operator
from dataclasses import dataclass
from typing import Any

import yaml

from twig_ecs.errors import SceneError
from twig_ecs.validate import check_keys, fail, join, mapping, read, suggest, text
from twig_ecs.yamldoc import YDict, YList

PARAMETER_KEYS = ("default", "min", "max", "about")
#: Formula cost caps: its length (characters) and the size of any whole number met on the way
#: (a float overflows by itself past 1e308, about 1024 bits).
MAX_FORMULA = 1000
MAX_BITS = 1100
#: Largest power (``**``) and number of digits (``round(x, n)``) a formula may ask for.
MAX_EXPONENT = 64
_FUNCTIONS = {"sqrt": math.sqrt, "ceil": math.ceil, "floor": math.floor, "round": round, "min": min,
              "max": max, "abs": abs}  # fmt: skip
_OPERATORS = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
              ast.FloorDiv: operator.floordiv, ast.Mod: operator.mod, ast.Pow: operator.pow,
              ast.USub: operator.neg, ast.UAdd: operator.pos}  # fmt: skip


@dataclass(frozen=True)
class Parameter:
    """One declared parameter: its default, bounds and a line of help."""

    name: str
    default: int | float
    low: float | None = None
    high: float | None = None
    about: str = ""

    def convert(self, value: Any) -> int | float:
        """``value`` (a number, or text from the command line) as this parameter's type.

        Raises ValueError with a message for a person when it does not fit.
        """
        kind = "an integer" if isinstance(self.default, int) else "a number"
        try:
            if isinstance(self.default, int):
                if isinstance(value, float) and value.is_integer():
                    value = int(value)
                if isinstance(value, bool) or not isinstance(value, (int, str)):
                    raise ValueError
                number: int | float = int(value)
            else:
                if isinstance(value, bool):
                    raise ValueError
                number = float(value)
                if not math.isfinite(number):
                    raise ValueError
        except (ValueError, OverflowError):  # OverflowError: a whole number past 1e308
            raise ValueError(f"parameter '{self.name}' must be {kind}, got {_show(value)}") from None
        if (self.low is not None and number < self.low) or (self.high is not None and number > self.high):
            raise ValueError(f"parameter '{self.name}' must be between {self.low:g} and {self.high:g}, "
                             f"got {number:g}")  # fmt: skip
        return number


def _show(value: Any) -> str:
    """``value`` for an error message, never more than 60 characters (a 300-digit number)."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def read_parameters(doc: YDict) -> dict[str, Parameter]:
    """The ``parameters:`` block of a scene document (empty when it has none)."""
    if "parameters" not in doc:
        return {}
    block = read(doc, "parameters", "", mapping)
    out = {}
    for name in block:
        here = join("parameters", str(name))
        if not str(name).isidentifier():
            fail(block, name, here, "a parameter name must be a plain word (letters, digits, _)")
        spec = block[name]
        if not isinstance(spec, dict):  # `count: 100` is a default with no bounds
            spec = YDict({"default": spec})
            spec.file, spec.line = block.where(name)
        check_keys(spec, here, PARAMETER_KEYS)
        default = read(spec, "default", here, _number)
        low = read(spec, "min", here, _number, None)
        high = read(spec, "max", here, _number, None)
        param = Parameter(str(name), default, low, high, read(spec, "about", here, text, ""))
        try:
            param.convert(default)
        except ValueError as exc:
            fail(spec, "default", join(here, "default"), str(exc))
        out[str(name)] = param
    return out


def _number(value: Any) -> int | float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError("a number")
    return value


def resolve(declared: dict[str, Parameter], given: dict[str, Any], scene: str) -> dict[str, int | float]:
    """Defaults overridden by ``given``; unknown names and bad values raise SceneError."""
    values: dict[str, int | float] = {name: p.default for name, p in declared.items()}
    for name, value in given.items():
        if name not in declared:
            takes = ", ".join(declared) if declared else "none"
            raise SceneError(f"scene '{scene}' has no parameter '{name}'" + suggest(name, declared)
                             + f" (it takes: {takes})")  # fmt: skip
        try:
            values[name] = declared[name].convert(value)
        except ValueError as exc:
            raise SceneError(f"scene '{scene}': {exc}") from None
    return values


def overrides_of(given: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """``given`` split into (declared parameters, overrides: the names with a dot)."""
    plain = {name: value for name, value in given.items() if "." not in name}
    return plain, {name: value for name, value in given.items() if "." in name}


def override(doc: YDict, path: str, value: Any, scene: str) -> int:
    """Set the dotted ``path`` of a scene document to ``value`` (a string is read as a YAML
    scalar: ``"3"`` is 3, ``"true"`` True); returns how many places it set.

    ``BEHAVIOUR.KEY...`` sets KEY in every entity's ``behaviors`` entry that uses BEHAVIOUR,
    ``ENTITY.KEY...`` in that entity, ``settings.KEY...`` in the scene's settings. A path
    that matches nothing, or walks into something that is not a mapping, is a SceneError.
    """
    if isinstance(value, str):
        value = _scalar(value, path, scene)
    head, _, rest = path.partition(".")
    keys = rest.split(".")
    if not head or not all(keys):
        raise SceneError(f"scene '{scene}': '{path}' is not a dotted path such as attachment.safe_distance")
    places: list[Any] = []
    if head == "settings":
        places.append(doc.setdefault("settings", YDict()))
    entities = doc.get("entities")
    known: set[str] = {"settings"}
    for raw in entities if isinstance(entities, list) else ():
        if not isinstance(raw, dict):
            continue
        known.add(str(raw.get("name")))
        if raw.get("name") == head:
            places.append(raw)
        behaviours = raw.get("behaviors")
        for entry in behaviours if isinstance(behaviours, list) else ():
            if isinstance(entry, dict):
                known.add(str(entry.get("use")))
                if entry.get("use") == head:
                    places.append(entry)
    if not places:
        raise SceneError(f"scene '{scene}': no behaviour, entity or settings called '{head}' to set "
                         f"'{path}'" + suggest(head, sorted(known)))  # fmt: skip
    for place in places:
        for depth, key in enumerate(keys[:-1]):
            inner = place.get(key)
            if inner is None:
                inner = place[key] = YDict()
            if not isinstance(inner, dict):
                where = ".".join([head, *keys[: depth + 1]])
                raise SceneError(f"scene '{scene}': cannot set '{path}': '{where}' is not a mapping")
            place = inner
        place[keys[-1]] = value
    return len(places)


def _scalar(text: str, path: str, scene: str) -> Any:
    """A command line's value as YAML reads it, refused unless a scalar or a list of them."""
    try:
        value = yaml.safe_load(text) if len(text) <= MAX_FORMULA else None
    except yaml.YAMLError:
        value = None
    plain = (int, float, str, bool)
    if isinstance(value, plain) or (isinstance(value, list) and all(isinstance(v, plain) for v in value)):
        return YList(value) if isinstance(value, list) else value
    raise SceneError(
        f"scene '{scene}': '{path}={text}': give a number, a word, true/false or a list of those"
    )


def substitute(node: Any, values: dict[str, int | float], path: str = "") -> Any:
    """Replace ``$name`` and ``$(formula)`` strings in a document, in place; returns the node."""
    if isinstance(node, dict):
        for key in list(node):
            if key == "parameters" and not path:
                continue
            here = join(path, str(key))
            value = node[key]
            if isinstance(value, str) and value.startswith("$"):
                node[key] = _evaluate(value, values, lambda msg, k=key, h=here: fail(node, k, h, msg))
            else:
                substitute(value, values, here)
    elif isinstance(node, list):
        for i, value in enumerate(node):
            here = f"{path}[{i}]"
            if isinstance(value, str) and value.startswith("$"):
                file, line = node.where(i) if isinstance(node, YList) else ("<string>", 0)
                node[i] = _evaluate(value, values, lambda msg, h=here, f=file, n=line: _raise(msg, f, n, h))
            else:
                substitute(value, values, here)
    return node


def _raise(message: str, file: str, line: int, path: str) -> None:
    raise SceneError(message, file, line, path)


def _evaluate(source: str, values: dict[str, int | float], error) -> int | float:
    """The value of ``$name`` or ``$(formula)``; ``error(message)`` raises."""
    body = source[1:]
    if body.startswith("(") and body.endswith(")"):
        body = body[1:-1]
    elif not body.isidentifier():
        error(f"'{source}': write $name or $(formula)")
    if len(body) > MAX_FORMULA:
        error(f"'{source[:40]}...': a formula is at most {MAX_FORMULA} characters (this one {len(body)})")
    try:
        tree = ast.parse(body, mode="eval")
    except (SyntaxError, RecursionError, MemoryError):
        error(f"'{source[:60]}' is not a formula (or is nested too deeply)")
    try:
        return _eval(tree.body, values)
    except NameError as exc:
        name = str(exc)
        error(f"'{source}': unknown parameter '{name}'" + suggest(name, values))
    except (ValueError, TypeError, ZeroDivisionError, OverflowError) as exc:
        error(f"'{source}': {exc}")
    except RecursionError:
        error(f"'{source[:60]}': nested too deeply")
    raise AssertionError("unreachable")


def _small(value: int | float) -> int | float:
    """``value`` if it is a number of bounded size: every step of a formula stays cheap."""
    if isinstance(value, int) and value.bit_length() > MAX_BITS:
        raise ValueError(f"number too large (more than {MAX_BITS} bits)")
    return value


def _eval(node: ast.AST, values: dict[str, int | float]) -> int | float:
    """Evaluate a formula's tree: numbers, parameters, arithmetic and a few functions only."""
    if isinstance(node, ast.Constant) and type(node.value) in (int, float):
        return node.value
    if isinstance(node, ast.Name):
        if node.id not in values:
            raise NameError(node.id)
        return values[node.id]
    if isinstance(node, ast.BinOp) and type(node.op) in _OPERATORS:
        left, right = _eval(node.left, values), _eval(node.right, values)
        if isinstance(node.op, ast.Pow):
            if abs(right) > MAX_EXPONENT:
                raise ValueError("exponent too large")  # 10**10**10 would never finish
            if isinstance(left, int) and left.bit_length() * abs(right) > MAX_BITS:
                raise ValueError(f"number too large (more than {MAX_BITS} bits)")  # (10**64)**64**64...
        return _small(_OPERATORS[type(node.op)](left, right))
    if isinstance(node, ast.UnaryOp) and type(node.op) in _OPERATORS:
        return _small(_OPERATORS[type(node.op)](_eval(node.operand, values)))
    if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in _FUNCTIONS
            and not node.keywords):  # fmt: skip
        args = [_eval(a, values) for a in node.args]
        if node.func.id == "round" and len(args) == 2 and abs(args[1]) > MAX_EXPONENT:
            # round(1, -10**8) works out 10**(10**8) first: minutes, for one number
            raise ValueError(f"round's digits must be from -{MAX_EXPONENT} to {MAX_EXPONENT}")
        return _small(_FUNCTIONS[node.func.id](*args))
    raise ValueError(f"'{ast.unparse(node)}' is not allowed (numbers, parameters, + - * / // % **, "
                     + ", ".join(_FUNCTIONS) + ")")  # fmt: skip
