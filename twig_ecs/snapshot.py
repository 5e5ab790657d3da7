"""Snapshot files: the whole state of a scene in one versioned, checksummed file.

A snapshot holds everything a scene needs to run on exactly as it would have: the
physics store, every esper entity and component, the systems and behaviours with their
own state, the RNG, pending goals, grab joints, the clock and the scene's own event
subscribers. Restoring it and stepping gives the same :meth:`Scene.state_hash` as never
having stopped.

File layout (all integers big-endian)::

    b"TWIGSNAP"              8 bytes, magic
    format version           u16 (FORMAT_VERSION)
    meta length              u32, then that many bytes of UTF-8 JSON (scene, frame, plug-ins...)
    payload length           u64, then that many bytes of pickle (protocol 5)
    SHA-256                  32 bytes, of everything before it

**Snapshot files are data** unless the user trusts them (``--trust``, see
:mod:`twig_ecs.trust`): the payload is a pickle, read with a restricted unpickler that
admits only classes of twig_ecs (not those that do input/output when built), plain numpy
values (arrays, dtypes, scalars, random generators - no memmap), esper, a few harmless
builtins, and the plug-in modules the snapshot lists - and those only when they are
installed twig plug-ins, were loaded by this process from a scene the user ran, or the
user trusts the file. A pickle is a program, so keep to snapshots you wrote or trust.

Numba kernels and anything with a socket are not state: systems hold kernels by
module reference (a kernel object met while pickling is stored as its name and looked
up again), and outside observers (a server, a window, a metrics recorder) subscribe
again to the restored scene. Only subscribers that belong to the scene - its systems'
methods and importable functions - are kept; the rest are listed in the meta as
``dropped``.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import inspect
import io
import json
import pickle
import struct
import sys
from pathlib import Path
from typing import Any

import esper

from twig_ecs import esperworld
from twig_ecs.behavior import Mind
from twig_ecs.errors import TwigError
from twig_ecs.kernels import ensure_compiled
from twig_ecs.trust import UntrustedCode, check_snapshot_plugin
from twig_ecs.version import __version__

MAGIC = b"TWIGSNAP"
#: Version of the file layout and of what the payload holds; bump on any change.
FORMAT_VERSION = 3  # 2: a scene holds its plugins and an event bus; nodes and links are no longer entities
# 3: hands gliding in a hug or an embrace are a character-table column (hand_aim), not a HandAims component
_HEAD = struct.Struct(">8sHI")
_LEN = struct.Struct(">Q")
_DIGEST = 32
#: Scene attributes that belong to this process, not to the world.
_TRANSIENT = ("_world", "_installed", "_closed")
#: Builtins a snapshot may name: containers and plain values only.
_SAFE_BUILTINS = {"set", "frozenset", "dict", "list", "tuple", "int", "float", "complex", "bool", "str",
                  "bytes", "bytearray", "slice", "range", "object", "NoneType"}  # fmt: skip
_SAFE_OTHERS = {
    ("collections", "Counter"),
    ("collections", "OrderedDict"),
    ("collections", "defaultdict"),
    ("collections", "deque"),
    ("pathlib", "PosixPath"),
    ("pathlib", "PurePosixPath"),
    ("pathlib", "WindowsPath"),
    ("pathlib", "PureWindowsPath"),
    ("copyreg", "_reconstructor"),
}
_SAFE_PACKAGES = ("twig_ecs", "numpy", "esper")
_SAFE_FUNCTIONS = {
    ("numpy._core.multiarray", "_reconstruct"),
    ("numpy._core.multiarray", "scalar"),
    ("numpy._core.numeric", "_frombuffer"),
    ("numpy.core.multiarray", "_reconstruct"),
    ("numpy.core.multiarray", "scalar"),
    ("numpy.core.numeric", "_frombuffer"),
    ("numpy.random._pickle", "__generator_ctor"),
    ("numpy.random._pickle", "__bit_generator_ctor"),
    ("numpy.random._pickle", "__randomstate_ctor"),
    ("numpy.random.bit_generator", "__pyx_unpickle_SeedSequence"),
    ("twig_ecs.snapshot", "_new_scene"),
    ("twig_ecs.snapshot", "_kernel"),
}


#: Modules of allowed packages whose classes do input/output when built (a recorder opens its
#: file): a snapshot never holds them, so it may not name them.
_IO_MODULES = ("twig_ecs.replay", "twig_ecs.server", "twig_ecs.client", "twig_ecs.graphics", "twig_ecs.bench",
               "twig_ecs.cli", "twig_ecs.report", "twig_ecs.metrics", "twig_ecs.__main__")  # fmt: skip


def _plain_class(top: str, cls: type) -> bool:
    """A class a snapshot may build: of numpy only dtypes, scalars, plain arrays and generators."""
    if top != "numpy":
        return True
    import numpy as np

    if cls is np.ndarray or issubclass(cls, np.dtype | np.generic):
        return True
    return cls.__module__.startswith("numpy.random") and issubclass(
        cls, np.random.Generator | np.random.BitGenerator | np.random.SeedSequence
    )


class SnapshotError(TwigError):
    """A snapshot that cannot be written or read (not a snapshot, corrupt, other version...)."""


# -- writing ---------------------------------------------------------------------------------


def snapshot(scene) -> bytes:
    """The bytes of a snapshot of ``scene`` (see the module docstring for the layout)."""
    scene.activate()
    dropped: list[str] = []
    handlers = scene._handlers  # noqa: SLF001 - the snapshot is the scene's own serialiser
    kept = {kind: [h for h in hs if _belongs(scene, h, dropped, f"subscriber of '{kind}'")]
            for kind, hs in handlers.items()}  # fmt: skip
    goals = _goals(scene)
    callbacks = [(goal, goal.on_end) for goal in goals]
    try:
        scene._handlers = {kind: hs for kind, hs in kept.items() if hs}  # noqa: SLF001
        for goal in goals:
            if goal.on_end is not None and not _belongs(
                scene, goal.on_end, dropped, f"on_end of goal {goal.id}"
            ):
                goal.on_end = None
        buffer = io.BytesIO()
        pickler = _Pickler(buffer, scene)
        pickler.dump((scene, esperworld.capture()))
    except SnapshotError:
        raise
    except Exception as exc:  # something in the world that cannot be saved: say what
        raise SnapshotError(f"cannot snapshot scene '{scene.name}': {type(exc).__name__}: {exc}") from None
    finally:
        scene._handlers = handlers  # noqa: SLF001
        for goal, on_end in callbacks:
            goal.on_end = on_end
    meta = {
        "twig_ecs": __version__,
        "scene": scene.name,
        "seed": scene.seed,
        "frame": scene.frame,
        "time": scene.time,
        "state_hash": scene.state_hash(),
        "plugins": _plugin_files(pickler.plugins),
        "dropped": dropped,
    }
    meta_bytes = json.dumps(meta).encode()
    payload = buffer.getvalue()
    body = _HEAD.pack(MAGIC, FORMAT_VERSION, len(meta_bytes)) + meta_bytes + _LEN.pack(len(payload)) + payload
    return body + hashlib.sha256(body).digest()


def save(scene, path: str | Path) -> dict[str, Any]:
    """Write a snapshot of ``scene`` to ``path``; returns its meta."""
    data = snapshot(scene)
    try:
        Path(path).write_bytes(data)
    except OSError as exc:
        raise SnapshotError(f"cannot write snapshot '{path}': {exc.strerror}") from None
    return read_meta(data)


def _goals(scene) -> list:
    return [goal for _, mind in esper.get_component(Mind) for goal in mind.goals]


def _belongs(scene, fn: Any, dropped: list[str], what: str) -> bool:
    """Is callable ``fn`` part of the scene (a system's method, an importable function or class)?"""
    owner = getattr(fn, "__self__", None)
    if inspect.ismethod(fn) or (owner is not None and not inspect.ismodule(owner)):
        ok = owner is scene or any(owner is s for s in scene.schedule.systems())
    elif inspect.isfunction(fn):
        ok = "<" not in fn.__qualname__ and _importable(fn.__module__, fn.__qualname__, fn)
    else:  # a callable object (like systems.attachment.Soothe): its class must be importable
        kind = type(fn)
        ok = "<" not in kind.__qualname__ and _importable(kind.__module__, kind.__qualname__, kind)
    if not ok:
        dropped.append(f"{what}: {getattr(fn, '__qualname__', type(fn).__qualname__)}")
    return ok


def _importable(module: str, qualname: str, obj: Any) -> bool:
    found: Any = sys.modules.get(module)
    for part in qualname.split("."):
        found = getattr(found, part, None)
    return found is obj


def _plugin_files(modules: list[str]) -> list[dict[str, str | None]]:
    """Each plug-in module with the file it was loaded from (file plug-ins are not importable by name)."""
    return [{"module": m, "file": getattr(sys.modules.get(m), "__file__", None)} for m in modules]


class _Pickler(pickle.Pickler):
    """Pickles the scene without its process-bound parts, kernels by name, and refuses sockets."""

    def __init__(self, file: io.BytesIO, scene) -> None:
        super().__init__(file, protocol=5)
        self.scene = scene
        self.plugins: list[str] = []  # modules outside twig_ecs, numpy and esper that classes come from

    def reducer_override(self, obj: Any) -> Any:
        if obj is self.scene:  # the root: its systems point back at it, so pickle keeps one scene
            state = {k: v for k, v in obj.__dict__.items() if k not in _TRANSIENT}
            return _new_scene, (type(obj),), state
        if isinstance(obj, type):
            where = obj.__module__
            plain = where.split(".")[0] in _SAFE_PACKAGES or (where, obj.__qualname__) in _SAFE_OTHERS
            if not plain and where != "builtins" and where not in self.plugins:
                self.plugins.append(where)
            return NotImplemented
        kind = type(obj)
        module = kind.__module__ or ""
        if module.startswith("numba"):
            name, where = getattr(obj, "__name__", None), getattr(obj, "__module__", None)
            if name and where and getattr(sys.modules.get(where), name, None) is obj:
                return _kernel, (where, name)  # looked up again (and loaded from numba's cache)
            raise SnapshotError(f"cannot snapshot a numba object that is not a module-level kernel: {obj!r}")
        if module in ("socket", "ssl", "_thread", "threading") or module.startswith("asyncio"):
            raise SnapshotError(
                f"cannot snapshot a {kind.__name__} held in the world: keep connections and threads outside "
                "the scene (a system attribute holding one should be rebuilt in setup())"
            )
        return NotImplemented


#: The scene class (:class:`~twig_ecs.scene.Scene` registers itself when it is defined): a
#: snapshot holds one of it or of a subclass, nothing else.
_scene_classes: list[type] = []


def register_scene_class(cls: type) -> None:
    """Name the class whose objects (or whose subclasses' objects) snapshots hold."""
    if cls not in _scene_classes:
        _scene_classes.append(cls)


def _is_scene_class(cls: object) -> bool:
    return isinstance(cls, type) and any(issubclass(cls, base) for base in _scene_classes)


def _new_scene(cls: type) -> Any:
    """An empty scene object of class ``cls``, to be filled from the snapshot."""
    if not _is_scene_class(cls):
        raise SnapshotError("snapshot corrupt: it does not hold a scene")
    return cls.__new__(cls)


def _kernel(module: str, name: str) -> Any:
    """A compiled kernel by its module and name (what the pickler stores for one)."""
    if not module.startswith("twig_ecs."):
        raise SnapshotError(f"snapshot names a kernel outside twig_ecs: {module}.{name}")
    return getattr(importlib.import_module(module), name)


# -- reading ---------------------------------------------------------------------------------


def read_meta(data: bytes) -> dict[str, Any]:
    """The meta of a snapshot (scene, frame, time, state_hash, plug-ins, dropped), checked."""
    meta, _payload = _split(data)
    return meta


def _split(data: bytes) -> tuple[dict[str, Any], bytes]:
    """Check magic, version and checksum; return (meta, payload)."""
    if not isinstance(data, bytes | bytearray | memoryview):
        raise SnapshotError(f"a snapshot is bytes, got {type(data).__name__}")
    data = bytes(data)
    if data[:8] != MAGIC:
        raise SnapshotError("not a twig snapshot (it does not start with TWIGSNAP)")
    if len(data) < _HEAD.size:
        raise SnapshotError(f"snapshot truncated: {len(data)} bytes, not even a whole header")
    _magic, version, meta_len = _HEAD.unpack_from(data)
    if version != FORMAT_VERSION:
        raise SnapshotError(
            f"snapshot format version {version}; this twig-ecs reads version {FORMAT_VERSION} "
            "(write it again with the twig-ecs that reads it, or run the twig-ecs that wrote it)"
        )
    at = _HEAD.size + meta_len
    if len(data) < at + _LEN.size + _DIGEST:
        raise SnapshotError(f"snapshot truncated: {len(data)} bytes, the header promises more")
    (payload_len,) = _LEN.unpack_from(data, at)
    end = at + _LEN.size + payload_len
    if len(data) != end + _DIGEST:
        raise SnapshotError(f"snapshot truncated or padded: {len(data)} bytes, expected {end + _DIGEST}")
    if hashlib.sha256(data[:end]).digest() != data[end:]:
        raise SnapshotError("snapshot corrupt: its checksum does not match its contents")
    try:
        meta = json.loads(data[_HEAD.size : at])
    except ValueError:
        raise SnapshotError("snapshot corrupt: unreadable meta") from None
    if not isinstance(meta, dict):
        raise SnapshotError("snapshot corrupt: unreadable meta")
    return meta, data[at + _LEN.size : end]


def restore(data: bytes):
    """A new :class:`~twig_ecs.scene.Scene` from snapshot bytes (see :meth:`Scene.restore`)."""
    meta, payload = _split(data)
    allowed = _import_plugins(meta.get("plugins", []))
    try:
        scene, world = _Unpickler(io.BytesIO(payload), allowed).load()
    except SnapshotError:
        raise
    except Exception as exc:
        raise SnapshotError(f"snapshot unreadable: {type(exc).__name__}: {exc}") from None
    if not _is_scene_class(type(scene)) or not isinstance(world, dict):
        raise SnapshotError("snapshot corrupt: it does not hold a scene")
    scene._world = esperworld.new_world_name()  # noqa: SLF001
    scene._closed = False  # noqa: SLF001
    scene._installed = None  # noqa: SLF001 - systems are re-installed as esper processors
    previous = esper.current_world
    scene.activate()
    try:
        esperworld.restore(world)
    except Exception as exc:
        scene.close()
        why = type(exc).__name__
        raise SnapshotError(f"snapshot corrupt: its entities cannot be restored ({why})") from None
    finally:
        if previous in esper.list_worlds() and previous != esper.current_world:
            esper.switch_world(previous)
    ensure_compiled()
    if scene.state_hash() != meta.get("state_hash"):
        scene.close()
        raise SnapshotError("snapshot corrupt: the restored positions do not match its state hash")
    return scene


def load(path: str | Path):
    """A scene restored from a snapshot file."""
    try:
        data = Path(path).read_bytes()
    except OSError as exc:
        raise SnapshotError(f"cannot read snapshot '{path}': {exc.strerror}") from None
    return restore(data)


def _import_plugins(plugins: Any) -> set[str]:
    """Import the plug-in modules a snapshot needs (by name, else from their file); their names."""
    names = set()
    if not isinstance(plugins, list):
        raise SnapshotError("snapshot corrupt: bad plug-in list")
    for item in plugins:
        module, file = (item.get("module"), item.get("file")) if isinstance(item, dict) else (None, None)
        if not isinstance(module, str) or not isinstance(file, str | None):
            raise SnapshotError("snapshot corrupt: bad plug-in list")
        try:
            check_snapshot_plugin(module, file)
        except UntrustedCode as exc:
            raise SnapshotError(str(exc)) from None
        if module not in sys.modules:
            try:
                if file and Path(file).is_file() and module.startswith("twig_plugin_"):
                    spec = importlib.util.spec_from_file_location(module, file)
                    assert spec is not None and spec.loader is not None
                    loaded = importlib.util.module_from_spec(spec)
                    sys.modules[module] = loaded
                    spec.loader.exec_module(loaded)
                else:
                    importlib.import_module(module)
            except Exception as exc:
                sys.modules.pop(module, None)
                raise SnapshotError(
                    f"snapshot needs plug-in module '{module}'"
                    + (f" ({file})" if file else "")
                    + f", which cannot be imported: {type(exc).__name__}: {exc}"
                ) from None
        names.add(module)
    return names


class _Unpickler(pickle.Unpickler):
    """Admits twig_ecs, numpy, esper, plain builtins and the snapshot's plug-in modules only."""

    def __init__(self, file: io.BytesIO, plugins: set[str]) -> None:
        super().__init__(file)
        self.plugins = plugins

    def find_class(self, module: str, name: str) -> Any:
        top = module.split(".")[0]
        if (module == "builtins" and name in _SAFE_BUILTINS) or (module, name) in _SAFE_OTHERS:
            return super().find_class(module, name)
        if (top in _SAFE_PACKAGES or module in self.plugins) and not module.startswith(_IO_MODULES):
            found = super().find_class(module, name)
            # classes only, and the few functions that rebuild arrays, generators, scenes and kernels:
            # an arbitrary function of an allowed module could still do anything; and of numpy only
            # plain values (an ndarray subclass such as memmap opens files when built)
            if (module, name) in _SAFE_FUNCTIONS or (isinstance(found, type) and _plain_class(top, found)):
                return found
        raise SnapshotError(
            f"snapshot refers to {module}.{name}, which a snapshot may not load "
            "(only classes of twig_ecs, numpy, esper and its listed plug-ins, and plain builtins)"
        )
