"""A scene's object graph as data: JSON for the structure, one binary blob for the arrays.

Snapshots are files from elsewhere, so reading one must never run code the file chooses
(a pickle can call anything it may name). This codec writes only plain values, and reads
back only what a closed schema allows:

- JSON scalars (``None``, bools, ints, floats - NaN and infinities as JSON's extensions -
  and strings);
- lists, tuples, dicts, sets and frozensets, bytes, complex numbers and paths;
- numpy arrays of plain numbers (bool, int, uint, float, complex; no objects, no
  structured types), numpy scalars and dtypes of those, and numpy random generators by
  their bit generator's *state* (PCG64 and friends, named from a fixed list);
- objects of **world classes** - the classes defined in the modules listed in
  :data:`WORLD_MODULES` (components, systems, behaviours, the store, the scene...) and in
  plug-in modules the caller allows - rebuilt with ``cls.__new__(cls)`` and their
  attributes set directly: no ``__init__``, no ``__reduce__``, no ``__setstate__``. A
  class with a ``__getstate__`` of its own (one that leaves its caches out) has it
  applied to what was read as well, so a cache never comes from a file;
- bound methods of such objects (an event handler such as ``system.on_pain``): a public
  function of the object's own class, looked up on the class;
- numba kernels of world modules, by module and name.

A class, kernel or method is looked up in a table made from the allowed modules when
reading starts, never by importing or walking a dotted name, so a file cannot reach
``subprocess`` through ``twig_ecs.kernels`` or build a class that does input/output
when used (the replay recorder, the kernel builder, the server, the window).

Layout of an encoded value (JSON): a scalar is itself; everything else is a JSON array
whose first item is a tag - ``["l", id, items]`` a list, ``["t", id, items]`` a tuple,
``["d", id, [[k, v], ...]]`` a dict, ``["s"/"f", id, items]`` a set/frozenset,
``["r", id]`` a reference to something met before (shared objects and cycles),
``["o", id, class, attrs, items]`` an object (items for dict and list subclasses),
``["a", id, dtype, shape, offset]`` an array in the blob, ``["n", dtype, value]`` a numpy
scalar, ``["y", dtype]`` a dtype, ``["T", class]`` a class, ``["g", id, generator]`` a
random generator, ``["m", object, name]`` a bound method, ``["k", module, name]`` a
kernel, ``["b", base64]`` bytes, ``["c", re, im]`` complex, ``["p", text]`` a path.
"""

from __future__ import annotations

import base64
import inspect
import json
import math
import re
import sys
from collections import Counter, OrderedDict
from collections.abc import Callable, Iterable
from pathlib import PurePath
from types import MethodType
from typing import Any

import numpy as np

from twig_ecs.errors import TwigError

#: Modules whose classes are world state (and may be rebuilt from a file). Packages end in ".".
WORLD_MODULES = (
    "twig_ecs.components.", "twig_ecs.systems.", "twig_ecs.behavior", "twig_ecs.mind", "twig_ecs.character",
    "twig_ecs.clock", "twig_ecs.world", "twig_ecs.events", "twig_ecs.goals", "twig_ecs.goalbook",
    "twig_ecs.grabs", "twig_ecs.handles", "twig_ecs.library", "twig_ecs.names", "twig_ecs.parameters",
    "twig_ecs.perturb", "twig_ecs.plugins", "twig_ecs.scene", "twig_ecs.scenefile", "twig_ecs.schedule",
    "twig_ecs.steering", "twig_ecs.store", "twig_ecs.system", "twig_ecs.templates", "twig_ecs.yamldoc",
    "twig_ecs.rowtable",
)  # fmt: skip
#: Classes outside those modules that a world holds as values.
_PLAIN_CLASSES: dict[str, type] = {
    "int": int, "float": float, "bool": bool, "str": str, "bytes": bytes, "complex": complex,
    "list": list, "tuple": tuple, "dict": dict, "set": set, "frozenset": frozenset, "NoneType": type(None),
    "collections:Counter": Counter, "collections:OrderedDict": OrderedDict,
}  # fmt: skip
#: numpy dtypes a snapshot may hold: plain numbers only (byte order, kind, size).
_DTYPE = re.compile(r"^[<>|=][biufc][0-9]{1,2}$")
_GENERATORS = ("PCG64", "PCG64DXSM", "MT19937", "Philox", "SFC64")
#: Most items of one array: a corrupt length cannot make us allocate more.
MAX_ITEMS = 50_000_000
#: Most values a structure may hold, and most bytes of it: reading costs about a microsecond a
#: value, so a file at these limits is read (or refused) in a few seconds. A world of 3000
#: walkers holds about 200 000 values in 4 MB; 10 000 bodies (the most a scene may have) fit.
MAX_VALUES = 1_000_000
MAX_STRUCTURE_BYTES = 16 << 20


class DataError(TwigError):
    """World data that cannot be written (not world state) or read (not what the schema allows)."""


def _in_world_module(module: str) -> bool:
    return any(module.startswith(m) if m.endswith(".") else module == m for m in WORLD_MODULES)


def _class_name(cls: type) -> str:
    return f"{cls.__module__}:{cls.__qualname__}"


def _is_kernel(obj: Any) -> bool:
    return type(obj).__module__.startswith("numba")


def _numpy_scalar_types() -> dict[str, type]:
    kinds = (np.bool_, np.int8, np.int16, np.int32, np.int64, np.uint8, np.uint16, np.uint32, np.uint64,
             np.float16, np.float32, np.float64, np.complex64, np.complex128)  # fmt: skip
    return {f"numpy:{k.__name__}": k for k in kinds}


class Schema:
    """The classes, kernels and plug-in modules a world may hold, by name (a closed table)."""

    def __init__(self, plugin_modules: Iterable[str] = ()) -> None:
        self.plugin_modules = set(plugin_modules)
        self.classes: dict[str, type] = dict(_PLAIN_CLASSES) | _numpy_scalar_types()
        self.kernels: dict[tuple[str, str], Any] = {}
        for name, module in list(sys.modules.items()):
            if module is None or not (_in_world_module(name) or name in self.plugin_modules):
                continue
            for attr, value in list(vars(module).items()):
                if isinstance(value, type) and value.__module__ == name:
                    self.add_class(value)
                elif _is_kernel(value) and getattr(value, "__module__", None) == name:
                    self.kernels[(name, attr)] = value

    def add_class(self, cls: type) -> None:
        """Admit ``cls`` (and the classes nested in it) as world state."""
        self.classes[_class_name(cls)] = cls
        for value in vars(cls).values():  # nested classes (Outer.Inner)
            if isinstance(value, type) and value.__module__ == cls.__module__ and value is not cls:
                if _class_name(value) not in self.classes:
                    self.add_class(value)

    def world_class(self, cls: type) -> bool:
        """May objects of ``cls`` be written and read back?"""
        return self.classes.get(_class_name(cls)) is cls

    def class_named(self, name: Any) -> type:
        """The class of a name read from a file (DataError if the schema has none)."""
        found = self.classes.get(name) if isinstance(name, str) else None
        if found is None:
            raise DataError(f"it names {name!r}, which is not a class a world may hold")
        return found


# -- writing -----------------------------------------------------------------------------------


def _custom_getstate(cls: type) -> bool:
    """Does ``cls`` say itself what of it is state (a ``__getstate__`` of its own, not dataclasses')?"""
    getstate = getattr(cls, "__getstate__", None)
    return inspect.isfunction(getstate) and getstate.__module__ not in ("dataclasses", "builtins")


def _attributes(obj: Any) -> dict[str, Any]:
    """An object's attributes: its own ``__getstate__`` if its class defines one, else dict and slots."""
    if _custom_getstate(type(obj)):
        state = obj.__getstate__()
        if not isinstance(state, dict):
            raise DataError(f"{type(obj).__qualname__}.__getstate__ must return a dict of attributes")
        return state
    state = dict(vars(obj)) if hasattr(obj, "__dict__") else {}
    for slot in _slot_names(type(obj)):
        if slot not in ("__dict__", "__weakref__") and hasattr(obj, slot):
            state[slot] = getattr(obj, slot)
    return state


class Encoder:
    """Turns an object graph into (JSON-able structure, array blob); see the module docstring.

    ``skip(obj)`` may return a dict of attributes to write instead of the object's own (the
    scene leaves out what belongs to this process); ``plugin_ok(module)`` says whether an
    object of a class from that (non-world) module may be written; such modules are
    collected in ``plugins``.
    """

    def __init__(self, schema: Schema, state_of: Callable[[Any], dict | None] = lambda obj: None,
                 plugin_ok: Callable[[str], bool] = lambda module: False) -> None:  # fmt: skip
        self.schema = schema
        self.state_of = state_of
        self.plugin_ok = plugin_ok
        self.plugins: list[str] = []
        self.memo: dict[int, int] = {}
        self.keep: list[Any] = []  # objects met, alive until the end (ids stay unique)
        self.blob = bytearray()

    def encode(self, obj: Any) -> Any:
        """The JSON-able form of ``obj`` (arrays go to :attr:`blob`)."""
        kind = type(obj)
        if obj is None or kind in (bool, int, float, str):
            return obj
        ref = self.memo.get(id(obj))
        if ref is not None:
            return ["r", ref]
        if kind is complex:
            return ["c", obj.real, obj.imag]
        if kind is bytes:
            return ["b", base64.b64encode(obj).decode()]
        if isinstance(obj, PurePath):
            return ["p", str(obj)]
        if isinstance(obj, np.generic):
            value = obj.item() if obj.dtype.kind != "c" else [obj.real.item(), obj.imag.item()]
            return ["n", self._dtype(obj.dtype), value]
        if isinstance(obj, np.dtype):
            return ["y", self._dtype(obj)]
        if isinstance(obj, type):
            return ["T", self._class(obj)]
        if isinstance(obj, MethodType):
            return self._method(obj)
        if _is_kernel(obj):
            return self._kernel(obj)
        ident = self._remember(obj)
        if kind is list:
            return ["l", ident, [self.encode(v) for v in obj]]
        if kind is tuple:
            return ["t", ident, [self.encode(v) for v in obj]]
        if kind is dict:
            return ["d", ident, [[self.encode(k), self.encode(v)] for k, v in obj.items()]]
        if kind is set or kind is frozenset:
            return ["s" if kind is set else "f", ident, [self.encode(v) for v in obj]]
        if kind is np.ndarray:
            return self._array(ident, obj)
        if isinstance(obj, np.random.Generator):
            return ["g", ident, self._generator(obj)]
        name = self._class(kind)
        state = self.state_of(obj)
        attrs = _attributes(obj) if state is None else state
        for key in attrs:
            if not isinstance(key, str):
                raise DataError(f"a {kind.__qualname__} has an attribute named {key!r}, not text")
        encoded_attrs = {key: self.encode(value) for key, value in attrs.items()}
        if isinstance(obj, dict):
            items = [[self.encode(k), self.encode(v)] for k, v in obj.items()]
        elif isinstance(obj, list):
            items = [self.encode(v) for v in obj]
        else:
            items = None
        return ["o", ident, name, encoded_attrs, items]

    def _remember(self, obj: Any) -> int:
        ident = len(self.memo)
        self.memo[id(obj)] = ident
        self.keep.append(obj)
        return ident

    def _dtype(self, dtype: np.dtype) -> str:
        if not _DTYPE.match(dtype.str):
            raise DataError(f"cannot write an array or value of numpy type {dtype} (plain numbers only)")
        return dtype.str

    def _class(self, cls: type) -> str:
        name = _class_name(cls) if cls.__module__ != "builtins" else cls.__name__
        if name.startswith("numpy:") or name in _PLAIN_CLASSES:
            if self.schema.classes.get(name) is cls:
                return name
        elif self.schema.world_class(cls):
            return name
        elif "<" not in cls.__qualname__ and self.plugin_ok(cls.__module__):
            if cls.__module__ not in self.plugins:
                self.plugins.append(cls.__module__)
            self.schema.plugin_modules.add(cls.__module__)
            self.schema.add_class(cls)  # the schema grows by the plug-ins met
            return name
        raise DataError(
            f"cannot write a {cls.__module__}.{cls.__qualname__}: it is not world state (keep "
            "connections, threads, files and outside objects out of the scene; a system attribute "
            "holding one should be rebuilt in setup())"
        )

    def _method(self, method: MethodType) -> list:
        owner, name = method.__self__, method.__func__.__name__
        if isinstance(owner, type) or getattr(type(owner), name, None) is not method.__func__:
            raise DataError(f"cannot write the callable {method!r}: only methods of world objects")
        return ["m", self.encode(owner), name]

    def _kernel(self, kernel: Any) -> list:
        key = (getattr(kernel, "__module__", None), getattr(kernel, "__name__", None))
        if self.schema.kernels.get(key) is not kernel:  # type: ignore[arg-type]
            raise DataError(f"cannot write a numba object that is not a kernel of a world module: {kernel!r}")
        return ["k", key[0], key[1]]

    def _array(self, ident: int, array: np.ndarray) -> list:
        dtype = self._dtype(array.dtype)
        offset = len(self.blob)
        self.blob += np.ascontiguousarray(array).tobytes()
        return ["a", ident, dtype, list(array.shape), offset]

    def _generator(self, rng: np.random.Generator) -> dict:
        bits = rng.bit_generator
        name = type(bits).__name__
        if name not in _GENERATORS or type(bits) is not getattr(np.random, name):
            raise DataError(f"cannot write a random generator over {name}")
        seq = bits.seed_seq
        seed = None
        if isinstance(seq, np.random.SeedSequence):
            seed = {"entropy": seq.entropy, "spawn_key": list(seq.spawn_key), "pool_size": seq.pool_size,
                    "n_children_spawned": seq.n_children_spawned}  # fmt: skip
        return {"bit_generator": name, "state": bits.state, "seed_seq": seed}


def encode(root: Any, schema: Schema, **options: Any) -> tuple[bytes, bytes, list[str]]:
    """(structure as UTF-8 JSON, array blob, plug-in modules met) of ``root``."""
    encoder = Encoder(schema, **options)
    structure = encoder.encode(root)
    if len(encoder.memo) > MAX_VALUES // 2:  # a rough guard: objects are about half the values
        raise DataError(f"the world holds {len(encoder.memo)} objects, too many to read back")
    text = json.dumps(structure, separators=(",", ":"), allow_nan=True, ensure_ascii=False)
    if len(text) > MAX_STRUCTURE_BYTES:
        raise DataError(f"its structure would be {len(text)} bytes, over {MAX_STRUCTURE_BYTES >> 20} MiB")
    return text.encode("utf-8", "surrogatepass"), bytes(encoder.blob), encoder.plugins


# -- reading -------------------------------------------------------------------------------------


class Decoder:
    """Rebuilds an object graph from :func:`encode`'s output, admitting only the schema's classes."""

    def __init__(self, schema: Schema, blob: bytes) -> None:
        self.schema = schema
        self.blob = memoryview(blob)
        self.memo: dict[int, Any] = {}
        self.values = 0

    def decode(self, node: Any) -> Any:
        """The object a JSON node stands for (DataError when it breaks the schema)."""
        self.values += 1
        if self.values > MAX_VALUES:
            raise DataError(f"it holds more than {MAX_VALUES} values, the most a world may")
        if node is None or type(node) in (bool, int, float, str):
            return node
        if type(node) is not list or not node or not isinstance(node[0], str):
            raise DataError(f"unexpected value {_short(node)}")
        tag = node[0]
        handler = self._tags.get(tag)
        if handler is None:
            raise DataError(f"unknown tag {tag!r}")
        return handler(self, node)

    def _fields(self, node: list, count: int) -> list:
        if len(node) != count:
            raise DataError(f"a {node[0]!r} item has {len(node)} fields, not {count}")
        return node

    def _new(self, ident: Any, obj: Any) -> Any:
        if type(ident) is not int or ident in self.memo:
            raise DataError(f"bad or repeated object id {_short(ident)}")
        self.memo[ident] = obj
        return obj

    def _items(self, items: Any) -> list:
        if type(items) is not list or len(items) > MAX_ITEMS:
            raise DataError("a container's items are not a list")
        return items

    def _ref(self, node: list) -> Any:
        _, ident = self._fields(node, 2)
        if type(ident) is not int or ident not in self.memo:
            raise DataError(f"a reference to an object not read yet ({_short(ident)})")
        return self.memo[ident]

    def _list(self, node: list) -> list:
        _, ident, items = self._fields(node, 3)
        out = self._new(ident, [])
        out.extend(self.decode(v) for v in self._items(items))
        return out

    def _tuple(self, node: list) -> tuple:
        _, ident, items = self._fields(node, 3)
        out = tuple(self.decode(v) for v in self._items(items))
        return self._new(ident, out)

    def _dict(self, node: list) -> dict:
        _, ident, items = self._fields(node, 3)
        out = self._new(ident, {})
        self._fill_dict(out, items)
        return out

    def _fill_dict(self, out: dict, items: Any) -> None:
        for pair in self._items(items):
            if type(pair) is not list or len(pair) != 2:
                raise DataError("a dict entry is not a [key, value] pair")
            dict.__setitem__(out, self.decode(pair[0]), self.decode(pair[1]))

    def _set(self, node: list) -> set | frozenset:
        tag, ident, items = self._fields(node, 3)
        values = [self.decode(v) for v in self._items(items)]
        return self._new(ident, set(values) if tag == "s" else frozenset(values))

    def _bytes(self, node: list) -> bytes:
        _, text = self._fields(node, 2)
        if not isinstance(text, str):
            raise DataError("bytes that are not base64 text")
        return base64.b64decode(text, validate=True)

    def _complex(self, node: list) -> complex:
        _, re_, im = self._fields(node, 3)
        return complex(_number(re_), _number(im))

    def _path(self, node: list) -> PurePath:
        from pathlib import Path

        _, text = self._fields(node, 2)
        if not isinstance(text, str):
            raise DataError("a path that is not text")
        return Path(text)

    def _scalar(self, node: list) -> np.generic:
        _, dtype, value = self._fields(node, 3)
        kind = _dtype(dtype)
        if kind.kind == "c":
            if type(value) is not list or len(value) != 2:
                raise DataError("a complex value that is not [re, im]")
            value = complex(_number(value[0]), _number(value[1]))
        elif type(value) not in (bool, int, float):
            raise DataError(f"a numpy {kind} that is not a number")
        with np.errstate(all="raise"):
            try:
                return kind.type(value)
            except (OverflowError, FloatingPointError, ValueError):
                raise DataError(f"{_short(value)} does not fit a numpy {kind}") from None

    def _dtype_node(self, node: list) -> np.dtype:
        _, dtype = self._fields(node, 2)
        return _dtype(dtype)

    def _type(self, node: list) -> type:
        _, name = self._fields(node, 2)
        return self.schema.class_named(name)

    def _array(self, node: list) -> np.ndarray:
        _, ident, dtype, shape, offset = self._fields(node, 5)
        kind = _dtype(dtype)
        if type(shape) is not list or not all(type(n) is int and 0 <= n <= MAX_ITEMS for n in shape):
            raise DataError(f"bad array shape {_short(shape)}")
        count = math.prod(shape)
        size = count * kind.itemsize
        if type(offset) is not int or offset < 0 or count > MAX_ITEMS or offset + size > len(self.blob):
            raise DataError("an array lies outside the array data")
        array = np.frombuffer(self.blob, dtype=kind, count=count, offset=offset).reshape(shape).copy()
        return self._new(ident, array)

    def _generator(self, node: list) -> np.random.Generator:
        _, ident, spec = self._fields(node, 3)
        if not isinstance(spec, dict) or spec.get("bit_generator") not in _GENERATORS:
            raise DataError("a random generator over an unknown bit generator")
        make = getattr(np.random, spec["bit_generator"])
        seed = spec.get("seed_seq")
        try:
            if seed is not None:
                if not isinstance(seed, dict) or not isinstance(seed.get("spawn_key"), list):
                    raise DataError("a random generator with a bad seed sequence")
                seq = np.random.SeedSequence(seed["entropy"], spawn_key=tuple(seed["spawn_key"]),
                                             pool_size=seed["pool_size"],
                                             n_children_spawned=seed["n_children_spawned"])  # fmt: skip
                bits = make(seq)
            else:
                bits = make()
            bits.state = spec["state"]
        except DataError:
            raise
        except (TypeError, ValueError, KeyError, OverflowError) as exc:
            raise DataError(f"a random generator with a bad state ({type(exc).__name__})") from None
        return self._new(ident, np.random.Generator(bits))

    def _object(self, node: list) -> Any:
        _, ident, name, attrs, items = self._fields(node, 5)
        cls = self.schema.class_named(name)
        if cls in _PLAIN_CLASSES.values() and cls not in (Counter, OrderedDict):
            raise DataError(f"a plain {name} written as an object")
        if not isinstance(attrs, dict):
            raise DataError(f"the attributes of a {name} are not a mapping")
        obj = self._new(ident, cls.__new__(cls))
        if issubclass(cls, dict):
            self._fill_dict(obj, items)
        elif issubclass(cls, list):
            list.extend(obj, (self.decode(v) for v in self._items(items)))
        elif items is not None:
            raise DataError(f"a {name} with items")
        slots = _slot_names(cls)
        for key, value in attrs.items():
            if not key.isidentifier() or key.startswith("__"):
                raise DataError(f"a {name} with an attribute named {key!r}")
            decoded = self.decode(value)
            if key in slots or not hasattr(obj, "__dict__"):
                try:
                    object.__setattr__(obj, key, decoded)
                except AttributeError:
                    raise DataError(f"a {name} has no attribute {key!r}") from None
            else:
                obj.__dict__[key] = decoded
        if _custom_getstate(cls) and hasattr(obj, "__dict__"):
            # the class says what of it is state (caches left out or emptied): what a file adds
            # beyond that is dropped, so no cache of row indices is ever taken from a file
            state = obj.__getstate__()
            obj.__dict__.clear()
            obj.__dict__.update(state)
        return obj

    def _method(self, node: list) -> MethodType:
        _, owner_node, name = self._fields(node, 3)
        owner = self.decode(owner_node)
        if not isinstance(name, str) or name.startswith("__"):
            raise DataError(f"a method named {_short(name)}")
        function = getattr(type(owner), name, None)
        if not inspect.isfunction(function) or not self.schema.world_class(type(owner)):
            raise DataError(f"{type(owner).__qualname__} has no method {name!r} a world may name")
        return MethodType(function, owner)

    def _kernel(self, node: list) -> Any:
        _, module, name = self._fields(node, 3)
        kernel = self.schema.kernels.get((module, name)) if isinstance(module, str) else None
        if kernel is None:
            raise DataError(f"it names a kernel {_short(module)}.{_short(name)} that no world module has")
        return kernel

    _tags: dict[str, Callable[[Decoder, list], Any]] = {
        "r": _ref, "l": _list, "t": _tuple, "d": _dict, "s": _set, "f": _set, "b": _bytes, "c": _complex,
        "p": _path, "n": _scalar, "y": _dtype_node, "T": _type, "a": _array, "g": _generator, "o": _object,
        "m": _method, "k": _kernel,
    }  # fmt: skip


def decode(structure: bytes, blob: bytes, schema: Schema) -> Any:
    """The object graph of :func:`encode`'s output; DataError for anything the schema does not allow."""
    if len(structure) > MAX_STRUCTURE_BYTES:
        raise DataError(f"its structure is {len(structure)} bytes, over {MAX_STRUCTURE_BYTES >> 20} MiB")
    try:
        tree = json.loads(structure.decode("utf-8", "surrogatepass"))
        return Decoder(schema, blob).decode(tree)
    except DataError:
        raise
    except RecursionError:
        raise DataError("nested too deeply") from None
    except (ValueError, UnicodeDecodeError) as exc:
        raise DataError(f"unreadable structure ({type(exc).__name__}: {str(exc)[:80]})") from None
    except (TypeError, AttributeError, KeyError, IndexError) as exc:
        # e.g. an unhashable value as a dict key, or a half-built object hashed
        raise DataError(f"inconsistent structure ({type(exc).__name__}: {str(exc)[:80]})") from None


def _slot_names(cls: type) -> dict[str, None]:
    """The slot names of ``cls`` and its bases, in a fixed order (a dict, for ``in``)."""
    names: dict[str, None] = {}
    for klass in cls.__mro__:
        slots = vars(klass).get("__slots__", ())
        names.update(dict.fromkeys((slots,) if isinstance(slots, str) else slots))
    return names


def _dtype(text: Any) -> np.dtype:
    if not isinstance(text, str) or not _DTYPE.match(text):
        raise DataError(f"numpy type {_short(text)} is not a plain number type")
    try:
        return np.dtype(text)
    except TypeError:
        raise DataError(f"numpy type {_short(text)} is not a plain number type") from None


def _number(value: Any) -> float:
    if type(value) not in (int, float):
        raise DataError(f"{_short(value)} is not a number")
    return value


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
