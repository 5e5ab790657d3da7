"""Snapshot files: the whole state of a scene in one versioned, checksummed file of data.

A snapshot holds everything a scene needs to run on exactly as it would have: the
physics store, every entity and component, the systems and behaviours with their
own state, the RNG, pending goals, grab joints, the clock and the scene's own event
subscribers. Restoring it and stepping gives the same :meth:`Scene.state_hash` as never
having stopped.

File layout (all integers big-endian)::

    b"TWIGSNAP"              8 bytes, magic
    format version           u16 (FORMAT_VERSION)
    meta length              u32, then that many bytes of UTF-8 JSON (scene, frame, plug-ins...)
    payload length           u64, then the payload:
        structure length     u64, then that many bytes of UTF-8 JSON (the object graph)
        arrays               the rest: the raw bytes of every numpy array, in order
    SHA-256                  32 bytes, of everything before it

**A snapshot is data, never code.** The payload is written and read by
:mod:`twig_ecs.worlddata`: plain values, arrays of numbers, and objects of the world's own
classes (components, systems, behaviours, the store...) rebuilt attribute by attribute
from a closed table - no pickle, and no name in the file is ever imported or resolved
to a function. Plug-in classes may appear only when their module is an installed twig
plug-in package, was loaded here from a scene the user ran, or the user trusts the file
(``--trust``): see :mod:`twig_ecs.trust`.

Numba kernels and anything with a socket are not state: a kernel met while saving is
stored by module and name and looked up again among the world modules' kernels, and
outside observers (a server, a window, a metrics recorder) subscribe again to the restored
scene. Only subscribers that belong to the scene - its systems' methods and callable world
objects - are kept; the rest are listed in the meta as ``dropped``.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import importlib.util
import inspect
import json
import struct
import sys
from pathlib import Path
from typing import Any

from twig_ecs import worlddata
from twig_ecs.behavior import Mind
from twig_ecs.components import Body, Character, GrabJoint
from twig_ecs.errors import TwigError
from twig_ecs.files import read_bounded
from twig_ecs.kernels import ensure_compiled
from twig_ecs.plugins import builtin_behaviors
from twig_ecs.store import check_store
from twig_ecs.trust import UntrustedCode, check_snapshot_plugin, is_trusted, module_allowed
from twig_ecs.version import __version__
from twig_ecs.world import World, check_world

MAGIC = b"TWIGSNAP"
#: Version of the file layout and of what the payload holds; bump on any change.
FORMAT_VERSION = 7  # 2: a scene holds its plugins and an event bus; nodes and links are no longer entities
# 3: hands gliding in a hug or an embrace are a character-table column (hand_aim), not a HandAims component
# 4: the payload is data (twig_ecs.worlddata: JSON structure + array bytes), no longer a pickle
# 5: systems live in feature packages (twig_ecs.systems.physics/control/behaviours): classes moved
# 6: a scene's entity names and goal holders are objects of their own (EntityNames, GoalBook)
# 7: a wanderer's target is a row of the wander behaviour's table (RowTable), not steer_* columns of the
#    store; the character table's face_dir and glance columns (glance.py; the same unreleased version)
_HEAD = struct.Struct(">8sHI")
_LEN = struct.Struct(">Q")
_DIGEST = 32
#: The largest snapshot file read (a corrupt length or a device file cannot make us read more):
#: 10 000 walkers (the most bodies a scene may have) take about 125 MB.
MAX_BYTES = 256 << 20
#: The largest meta (scene name, plug-in list, dropped subscribers...).
MAX_META_BYTES = 1 << 20
#: Scene attributes that belong to this process, not to the world.
_TRANSIENT = ("_installed", "_closed", "_threads")


class SnapshotError(TwigError):
    """A snapshot that cannot be written or read (not a snapshot, corrupt, other version...)."""


# -- writing ---------------------------------------------------------------------------------


def snapshot(scene) -> bytes:
    """The bytes of a snapshot of ``scene`` (see the module docstring for the layout)."""
    dropped: list[str] = []
    handlers = scene._handlers  # noqa: SLF001 - the snapshot is the scene's own serialiser
    kept = {kind: [h for h in hs if _belongs(scene, h, dropped, f"subscriber of '{kind}'")]
            for kind, hs in handlers.items()}  # fmt: skip
    goals = _goals(scene)
    callbacks = [(goal, goal.on_end) for goal in goals]

    def state_of(obj: Any) -> dict | None:
        if obj is scene:  # the root: what belongs to this process stays out
            return {k: v for k, v in vars(obj).items() if k not in _TRANSIENT}
        return None

    try:
        scene._handlers = {kind: hs for kind, hs in kept.items() if hs}  # noqa: SLF001
        for goal in goals:
            if goal.on_end is not None and not _belongs(
                scene, goal.on_end, dropped, f"on_end of goal {goal.id}"
            ):
                goal.on_end = None
        schema = worlddata.Schema()
        structure, arrays, plugins = worlddata.encode(
            scene, schema, state_of=state_of, plugin_ok=_writable_plugin
        )
    except worlddata.DataError as exc:
        raise SnapshotError(f"cannot snapshot scene '{scene.name}': {exc}") from None
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
        "plugins": _plugin_files(plugins),
        "dropped": dropped,
    }
    meta_bytes = json.dumps(meta).encode()
    payload = _LEN.pack(len(structure)) + structure + arrays
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
    return [goal for _, mind in scene.world.get_component(Mind) for goal in mind.goals]


#: Packages whose classes are never plug-in state (outside twig_ecs's own world modules).
_NOT_PLUGINS = {"__main__", "twig_ecs", "numpy", "numba", "esper", "pyglet", "moderngl", "yaml", "llvmlite"}


def _writable_plugin(module: str) -> bool:
    """May a snapshot hold objects of a class from ``module`` (outside the world modules)?

    A user's own code that extends the world (a plug-in file, an installed plug-in, a test
    module defining a system) - never the standard library or a library twig builds on.
    """
    top = module.split(".")[0]
    return module in sys.modules and top not in _NOT_PLUGINS and top not in sys.stdlib_module_names


def _belongs(scene, fn: Any, dropped: list[str], what: str) -> bool:
    """Is callable ``fn`` part of the scene: a method of the scene or a system, or a callable world object?

    Plain functions are left out: a snapshot names no function (it is data), so a
    module-level function subscribed to the scene is dropped and listed like a lambda.
    """
    owner = getattr(fn, "__self__", None)
    if inspect.ismethod(fn) or (owner is not None and not inspect.ismodule(owner)):
        ok = owner is scene or any(owner is s for s in scene.schedule.systems())
    elif inspect.isfunction(fn) or inspect.isbuiltin(fn):
        ok = False
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


#: The scene class (:class:`~twig_ecs.scene.Scene` registers itself when it is defined): a
#: snapshot holds one of it or of a subclass, nothing else.
_scene_classes: list[type] = []


def register_scene_class(cls: type) -> None:
    """Name the class whose objects (or whose subclasses' objects) snapshots hold."""
    if cls not in _scene_classes:
        _scene_classes.append(cls)


def _is_scene_class(cls: object) -> bool:
    return isinstance(cls, type) and any(issubclass(cls, base) for base in _scene_classes)


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
    if meta_len > MAX_META_BYTES:
        raise SnapshotError(
            f"snapshot corrupt: its meta is {meta_len} bytes, over {MAX_META_BYTES >> 10} KiB"
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
    except (ValueError, RecursionError):
        raise SnapshotError("snapshot corrupt: unreadable meta") from None
    if not isinstance(meta, dict):
        raise SnapshotError("snapshot corrupt: unreadable meta")
    return meta, data[at + _LEN.size : end]


def restore(data: bytes):
    """A new :class:`~twig_ecs.scene.Scene` from snapshot bytes (see :meth:`Scene.restore`)."""
    meta, payload = _split(data)
    builtin_behaviors()  # the class table is made from imported world modules: every behaviour's
    allowed = _import_plugins(meta.get("plugins", []))
    if len(payload) < _LEN.size:
        raise SnapshotError("snapshot corrupt: its payload is shorter than its own length field")
    (structure_len,) = _LEN.unpack_from(payload)
    structure = payload[_LEN.size : _LEN.size + structure_len]
    if len(structure) != structure_len:
        raise SnapshotError("snapshot corrupt: its structure runs past its payload")
    try:
        root = worlddata.decode(structure, payload[_LEN.size + structure_len :], worlddata.Schema(allowed))
    except worlddata.DataError as exc:
        raise SnapshotError(f"snapshot unreadable: {exc}") from None
    scene = root
    if not _is_scene_class(type(scene)) or not isinstance(getattr(scene, "world", None), World):
        raise SnapshotError("snapshot corrupt: it does not hold a scene")
    scene._reopen()  # noqa: SLF001 - the snapshot is the scene's own serialiser
    try:
        _check_scene_parts(scene)
        _check_systems(scene)
        check_store(scene.state)
        check_world(scene.world)
        _check_components(scene.world, scene.state)
        scene.state.version += 1  # every cache of row indices a system kept is made again
        ensure_compiled()
        matches = scene.state_hash() == meta.get("state_hash")
    except ValueError as exc:  # the parts are data, but not a world the kernels may walk
        scene.close()
        raise SnapshotError(f"snapshot corrupt: {exc}") from None
    except Exception as exc:  # a well-formed file whose parts do not fit together
        scene.close()
        why = type(exc).__name__
        raise SnapshotError(f"snapshot corrupt: its world cannot be restored ({why})") from None
    if not matches:
        scene.close()
        raise SnapshotError("snapshot corrupt: the restored positions do not match its state hash")
    return scene


@functools.cache
def _scene_parts(scene_class: type) -> dict[str, type]:
    """What a new empty scene of ``scene_class`` holds: attribute name -> the type of its value
    (None-valued ones - set later, or optional - left out)."""
    fresh = scene_class(plugins=[])
    try:
        return {name: type(value) for name, value in vars(fresh).items() if value is not None}
    finally:
        fresh.close()


def _check_scene_parts(scene) -> None:
    """A decoded scene has every part a scene has, each of its kind (ValueError naming the
    first that is not): a file that drops or swaps one must not fail later, mid-step."""
    held = vars(scene)
    for name, kind in _scene_parts(type(scene)).items():
        if name not in held:
            raise ValueError(f"its scene has no '{name}'")
        if not isinstance(held[name], kind):
            raise ValueError(f"its scene's '{name}' is a {type(held[name]).__name__}, not a {kind.__name__}")


def _check_systems(scene) -> None:
    """Each decoded system is the scene's (ValueError naming the first that is not): found by
    the snapshot fuzzer, a system whose ``scene`` key was renamed stepped into an AttributeError."""
    for system in scene.schedule.systems():
        if vars(system).get("scene") is not scene:
            raise ValueError(f"its {type(system).__name__} system is not the scene's")


def _check_components(world: World, state) -> None:
    """Components that hold store rows must point at rows that exist (ValueError saying which)."""
    nodes, links, bodies, characters = (state.nodes.count, state.links.count, state.bodies.count,
                                        state.characters.count)  # fmt: skip
    for entity, body in world.get_component(Body):
        size = len(body.node_names) if isinstance(body.node_names, tuple | list) else -1
        if not (
            _row(body.index, bodies) and _row(body.node_start, nodes) and 0 < size <= nodes - body.node_start
            and _row(body.link_start, links + 1) and type(body.link_count) is int
            and 0 <= body.link_count <= links - body.link_start
        ):  # fmt: skip
            raise ValueError(f"entity {entity}'s body points outside the store")
    for entity, character in world.get_component(Character):
        if not _row(character.index, characters):
            raise ValueError(f"entity {entity}'s character row is outside the store")
    for entity, joint in world.get_component(GrabJoint):
        if not _row(joint.index, links):
            raise ValueError(f"grab joint {entity}'s link row is outside the store")


def _row(value: Any, count: int) -> bool:
    return type(value) is int and 0 <= value < count


def load(path: str | Path):
    """A scene restored from a snapshot file (a regular file of at most :data:`MAX_BYTES`)."""
    return restore(read_bounded(path, MAX_BYTES, "snapshot", SnapshotError))


def _import_plugins(plugins: Any) -> set[str]:
    """Import the plug-in modules a snapshot needs (by name, else from their file); their names."""
    names = set()
    if not isinstance(plugins, list):
        raise SnapshotError("snapshot corrupt: bad plug-in list")
    for item in plugins:
        module, file = (item.get("module"), item.get("file")) if isinstance(item, dict) else (None, None)
        if not isinstance(module, str) or not isinstance(file, str | None):
            raise SnapshotError("snapshot corrupt: bad plug-in list")
        if module == "__main__" or module.startswith("twig_ecs.") or module == "twig_ecs":
            raise SnapshotError(f"snapshot corrupt: '{module}' is not a plug-in module")
        try:
            check_snapshot_plugin(module, file)
        except UntrustedCode as exc:
            raise SnapshotError(str(exc)) from None
        if module not in sys.modules:
            try:
                if file and is_trusted() and Path(file).is_file() and module.startswith("twig_plugin_"):
                    spec = importlib.util.spec_from_file_location(module, file)
                    assert spec is not None and spec.loader is not None
                    loaded = importlib.util.module_from_spec(spec)
                    sys.modules[module] = loaded
                    spec.loader.exec_module(loaded)
                elif is_trusted() or module_allowed(module):
                    importlib.import_module(module)
            except Exception as exc:
                sys.modules.pop(module, None)
                raise SnapshotError(
                    f"snapshot needs plug-in module '{module}'"
                    + (f" ({file})" if file else "")
                    + f", which cannot be imported: {type(exc).__name__}: {exc}"
                ) from None
        if module not in sys.modules:
            raise SnapshotError(f"snapshot needs plug-in module '{module}', which is not loaded")
        names.add(module)
    return names
