"""Record a served session and replay it headless: ``twig serve --record`` / ``twig run --replay``.

A replay file is JSON lines. The first line says what was served, with the files
themselves so the replay needs nothing else::

    {"twig_replay": 1, "scene": "schoolyard", "seed": 0, "content": [], "autonomous": true,
     "files": {"scene": {"path": ..., "text": ...}, "content": {DIR: {"bodies/x.yaml": TEXT}}}}

then one line per command the server applied, with the frame it was applied at (after
that many steps) and the error it gave, if any::

    {"frame": 120, "method": "hug", "params": {"character": "small_child", ...}, "error": null}

and, when the server stops, ``{"end": FRAME, "state_hash": HASH}``. Replaying loads the
same scene and seed, steps to each command's frame, applies it through the same method
function as the server did, steps to the end frame and compares the state hash.
A replay file is data (see :mod:`twig_ecs.trust`): it writes only its embedded ``.yaml``
files, only inside its temporary folder, and its scene runs no plug-in file unless the
user passes ``--trust``. Reading is bounded before any work: the file at most
:data:`MAX_REPLAY_BYTES` (a regular file), its embedded YAML at most
:data:`MAX_EMBEDDED_BYTES` in all, frames at most :data:`MAX_FRAMES` (an hour), the seed
0 to :data:`MAX_SEED`.
Only commands that reached the simulation are recorded: requests refused while being
checked (bad JSON, bad parameters) never touch the world. ``pause``, ``resume`` and
``step`` are clock controls: their effect is in the frame numbers.

A recording is bounded: a command the world refused keeps its parameters only up to
:data:`MAX_FAILED_PARAMS` bytes (longer ones are written as ``"params": null,
"params_cut": BYTES``; a replay skips them - they changed nothing), and the whole file
stops at its size limit (:data:`MAX_RECORD_BYTES`, ``twig serve --record-limit``): the
recorder then writes the end line for the world as it was before the command that did
not fit, and the server goes on unrecorded.
"""

from __future__ import annotations

import json
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

from twig_ecs.errors import TwigError
from twig_ecs.files import read_text_bounded
from twig_ecs.library import ContentLibrary
from twig_ecs.scene import Scene
from twig_ecs.server.commandlog import (  # noqa: F401 - MAX_*: the recording's limits are named here too
    CLOCK_METHODS,
    MAX_FAILED_PARAMS,
    MAX_RECORDED_ERROR,
    HeadlessSession,
    apply_records,
    command_record,
)
from twig_ecs.server.core import Server
from twig_ecs.trust import loading_data
from twig_ecs.validate import MAX_SEED, seed  # noqa: F401 - MAX_SEED: twig_ecs.replay names it here
from twig_ecs.yamldoc import MAX_BYTES as MAX_YAML_BYTES

FORMAT_VERSION = 1
#: Latest frame a replay may name: an hour at 60 Hz (a few minutes to replay a schoolyard),
#: so a two-line file cannot keep ``twig run --replay`` busy for hours.
MAX_FRAMES = 3600 * 60
#: Largest replay file: 80 000 commands of 100 bytes; read and checked in under a second.
MAX_REPLAY_BYTES = 8 * 1024 * 1024
#: Most YAML text a replay may embed (scene and content files together): each file is parsed
#: when the scene loads, at up to a second per 256 KiB.
MAX_EMBEDDED_BYTES = 512 * 1024
#: Frames stepped between two progress reports while replaying.
PROGRESS_FRAMES = 600
#: Size limit of a recording (bytes, header included): what a replay may hold, so every
#: recording can be replayed (``--record-limit`` may only lower it).
MAX_RECORD_BYTES = MAX_REPLAY_BYTES
#: Room kept for the end line when a recording fills up (bytes).
_END_ROOM = 400


class ReplayError(TwigError):
    """A replay file that cannot be read or replayed."""


def scene_files(source: str | Path, content: list[str] | tuple[str, ...] = ()) -> dict[str, Any]:
    """The scene file's text and every YAML file of the content folders, to embed in a recording."""
    path = ContentLibrary(content).scene_path(source)
    read = lambda f: read_text_bounded(f, MAX_EMBEDDED_BYTES, "file to record", ReplayError)  # noqa: E731
    out: dict[str, Any] = {"scene": {"path": str(path), "text": read(path)}, "content": {}}
    for folder in content:
        files = sorted(Path(folder).glob("*.yaml")) + sorted(Path(folder).glob("*/*.yaml"))
        out["content"][str(folder)] = {str(f.relative_to(folder)): read(f) for f in files}
    if _embedded_size(out) > MAX_EMBEDDED_BYTES:  # a replay could not carry them: say so now
        raise ReplayError(f"cannot record: the scene and content files are {_embedded_size(out)} bytes; "
                          f"a replay carries at most {MAX_EMBEDDED_BYTES // 1024} KiB of them")  # fmt: skip
    return out


class Recorder:
    """Writes a replay file as a server applies commands (see the module docstring).

    ``limit``: the most bytes the file may hold; :meth:`command` returns False (and writes
    nothing) for a command that would pass it, and the server then closes the recording.
    """

    def __init__(self, path: str | Path, source: str | Path, seed: int, content: list | tuple = (),
                 autonomous: bool = True, limit: int = MAX_RECORD_BYTES) -> None:  # fmt: skip
        self.path = Path(path)
        self.limit = limit
        self.size = 0
        header = {
            "twig_replay": FORMAT_VERSION,
            "scene": str(source),
            "seed": seed,
            "content": [str(c) for c in content],
            "autonomous": autonomous,
            "files": scene_files(source, content),
        }
        first = json.dumps(header) + "\n"
        if len(first.encode()) + _END_ROOM > limit:
            raise ReplayError(f"cannot record to '{path}': the scene's files alone are "
                              f"{len(first) / (1 << 20):.1f} MiB, over the recording's limit of "
                              f"{limit / (1 << 20):g} MiB (--record-limit)")  # fmt: skip
        try:
            self.file: IO[str] | None = open(path, "w", encoding="utf-8")  # noqa: SIM115 - open until close()
        except OSError as exc:
            raise ReplayError(f"cannot write replay file '{path}': {exc.strerror}") from None
        self.commands = 0
        self._write(first)

    def _write(self, line: str) -> None:
        if self.file is not None:
            self.file.write(line)
            self.file.flush()  # a crash keeps what was applied so far
            self.size += len(line.encode())

    def command(self, frame: int, method: str, params: dict[str, Any], error: str | None) -> bool:
        """One applied command: the frame it landed at, its checked parameters, its error.

        A failed command's parameters longer than MAX_FAILED_PARAMS are left out. False,
        with nothing written, when the line would take the file past its limit.
        """
        line = json.dumps(command_record(frame, method, params, error)) + "\n"
        if self.size + len(line.encode()) + _END_ROOM > self.limit:
            return False
        self.commands += 1
        self._write(line)
        return True

    def past_frames(self, frame: int) -> bool:
        """Has the world gone past the last frame a replay may name (:data:`MAX_FRAMES`)?"""
        return frame >= MAX_FRAMES

    @property
    def frames_note(self) -> str:
        """The end line's note when the recording reached the last frame a replay may name."""
        return f"recording stopped: a replay holds at most {MAX_FRAMES} frames (an hour)"

    @property
    def full_note(self) -> str:
        """The end line's note when the file reached its limit."""
        return f"recording stopped: the file reached its limit of {self.limit / (1 << 20):g} MiB"

    def close(self, frame: int, state_hash: str, note: str | None = None) -> None:
        """The end of the session: the final frame and state hash (once)."""
        if self.file is None:
            return
        end: dict[str, Any] = {"end": frame, "state_hash": state_hash}
        if note:
            end["note"] = note
        self._write(json.dumps(end) + "\n")
        self.file.close()
        self.file = None


def read_replay(path: str | Path, max_frames: int = MAX_FRAMES
                ) -> tuple[dict[str, Any], list[dict[str, Any]], dict[str, Any] | None]:  # fmt: skip
    """(header, commands, end) of a replay file; ReplayError if it is not one.

    Everything is checked here, before a scene loads: field types, the seed, the frames
    (in order, none past ``max_frames``) and the sizes of the file and its embedded files.
    """
    text = read_text_bounded(path, MAX_REPLAY_BYTES, "replay file", ReplayError)
    items = []
    for number, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        try:
            items.append(json.loads(line))
        except ValueError as exc:
            raise ReplayError(f"'{path}' is not a replay file (line {number} is not JSON: {exc})") from None
        except RecursionError:  # [[[[...]]]] thousands deep
            raise ReplayError(f"'{path}': line {number} is nested too deeply to be a replay record") from None
    if not items or not isinstance(items[0], dict) or "twig_replay" not in items[0]:
        raise ReplayError(f"'{path}' is not a replay file (no twig_replay header)")
    header = items[0]
    if header["twig_replay"] != FORMAT_VERSION:
        raise ReplayError(f"replay format version {header['twig_replay']!r:.40}; "
                          f"this twig-ecs reads {FORMAT_VERSION}")  # fmt: skip
    _check_header(header, path)
    end = items[-1] if len(items) > 1 and isinstance(items[-1], dict) and "end" in items[-1] else None
    commands = items[1 : len(items) - (1 if end else 0)]
    last = 0
    for k, item in enumerate(commands):
        ok = isinstance(item, dict) and _is_frame(item.get("frame"), max_frames)
        ok = ok and isinstance(item.get("method"), str) and isinstance(item.get("params") or {}, dict)
        if not ok:
            raise ReplayError(
                f"'{path}': line {k + 2} is not a command record "
                f"(needs frame: 0..{max_frames}, method: a name, params: an object)"
            )
        if item["frame"] < last:
            raise ReplayError(f"'{path}': line {k + 2}: commands out of order (frame {item['frame']} "
                              f"after frame {last})")  # fmt: skip
        last = item["frame"]
    if end is not None:
        if not _is_frame(end.get("end"), max_frames):
            hours, got = max_frames / (3600 * 60), _short(end.get("end"))
            raise ReplayError(f"'{path}': the end line's 'end' must be a frame number 0..{max_frames} "
                              f"({hours:g} h at 60 Hz, the longest replay), got {got}")  # fmt: skip
        if end["end"] < last:
            raise ReplayError(f"'{path}': the end line's frame {end['end']} is before the last command's "
                              f"({last})")  # fmt: skip
    return header, commands, end


def _is_seed(value: Any) -> bool:
    try:
        seed(value)
    except ValueError:
        return False
    return True


def _is_frame(value: Any, max_frames: int = MAX_FRAMES) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and 0 <= value <= max_frames


def _check_header(header: dict[str, Any], path: str | Path) -> None:
    """The header's fields have the types a replay needs (ReplayError naming the first that does not)."""
    checks = {
        "scene": lambda v: isinstance(v, str),
        "seed": _is_seed,
        "content": lambda v: isinstance(v, list) and all(isinstance(c, str) for c in v),
        "autonomous": lambda v: isinstance(v, bool),
        "files": lambda v: v is None or _files_ok(v),
    }
    for key, ok in checks.items():
        if key in header and not ok(header[key]):
            raise ReplayError(f"'{path}': the header's '{key}' has the wrong type or range "
                              f"({_short(header[key])})")  # fmt: skip
    if not isinstance(header.get("scene"), str):
        raise ReplayError(f"'{path}': the header names no scene")
    embedded = _embedded_size(header.get("files") or {})
    if embedded > MAX_EMBEDDED_BYTES:
        raise ReplayError(f"'{path}' embeds {embedded} bytes of YAML files; a replay may carry at most "
                          f"{MAX_EMBEDDED_BYTES // 1024} KiB")  # fmt: skip


def _short(value: Any) -> str:
    """A value for an error message: at most 60 characters, even for a huge number or deep list."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 200:
        return f"a {value.bit_length()}-bit number"
    try:
        text = repr(value)
    except (RecursionError, ValueError):
        return f"a {type(value).__name__}"
    return text if len(text) <= 60 else text[:57] + "..."


def _embedded_size(files: dict[str, Any]) -> int:
    """Bytes (about: characters) of the YAML texts a replay's header embeds."""
    texts = [(files.get("scene") or {}).get("text") or ""]
    texts += [t for folder in (files.get("content") or {}).values() for t in folder.values()]
    return sum(len(t) for t in texts)


def _files_ok(files: Any) -> bool:
    if not isinstance(files, dict):
        return False
    scene = files.get("scene") or {}
    content = files.get("content") or {}
    return (
        isinstance(scene, dict)
        and all(isinstance(scene.get(k), str) for k in ("path", "text") if k in scene)
        and isinstance(content, dict)
        and all(isinstance(t, dict) and all(isinstance(r, str) and isinstance(x, str) for r, x in t.items())
                for t in content.values())
    )  # fmt: skip


def _inside(root: Path, rel: str) -> Path:
    """``root / rel`` for an embedded YAML file, refusing anything that would land outside ``root``."""
    where = Path(rel)
    target = (root / where).resolve()
    if where.is_absolute() or ".." in where.parts or not target.is_relative_to(root.resolve()):
        raise ReplayError(f"the replay embeds a file named '{rel}': it would be written outside its folder")
    if where.suffix not in (".yaml", ".yml"):
        raise ReplayError(f"the replay embeds '{rel}'; a replay carries only .yaml files")
    return target


def _load_scene(header: dict[str, Any], folder: Path):
    """The recorded scene: from the recorded paths if unchanged, else from the embedded copies."""
    files = header.get("files") or {}
    scene_file = files.get("scene") or {}
    content = list(header.get("content", []))
    embedded = files.get("content") or {}
    # unchanged: the scene file and every YAML file of every content folder as embedded, and
    # no others (a replay naming a folder it does not embed would have any YAML there read)
    unchanged = _same(scene_file.get("path"), scene_file.get("text")) and all(
        _yaml_files(d) == set(embedded.get(d, {}))
        and all(_same(str(Path(d) / rel), text) for rel, text in embedded.get(d, {}).items())
        for d in content
    )
    if unchanged or not scene_file:
        source = scene_file.get("path") or header["scene"]
    else:
        content = []
        for k, (_d, texts) in enumerate(files.get("content", {}).items()):
            root = folder / f"content{k}"
            root.mkdir(parents=True, exist_ok=True)
            for rel, text in texts.items():
                target = _inside(root, rel)
                target.parent.mkdir(parents=True, exist_ok=True)
                target.write_text(text, encoding="utf-8")
            content.append(str(root))
        source = _inside(folder, Path(str(scene_file.get("path", "scene.yaml"))).name or "scene.yaml")
        source.write_text(scene_file.get("text", ""), encoding="utf-8")
    with loading_data():  # a replay is data: its scene may not run plug-in files unless --trust
        return Scene.load(source, seed=int(header.get("seed", 0)), content=content)


def _same(path: str | None, text: str | None) -> bool:
    """Does the file ``path`` hold ``text``? (Read bounded: the path comes from the replay.)"""
    if path is None or text is None:
        return False
    try:
        return read_text_bounded(path, MAX_YAML_BYTES, "recorded file") == text
    except TwigError:
        return False


def _yaml_files(folder: str) -> set[str]:
    """The YAML files a content folder holds, as :class:`ContentLibrary` reads them (relative paths)."""
    root = Path(folder)
    if not root.is_dir():
        return set()
    return {str(f.relative_to(root)) for f in [*root.glob("*.yaml"), *root.glob("*/*.yaml")]}


def replay(path: str | Path, log=None, progress: Callable[[int, int], None] | None = None,
           max_frames: int = MAX_FRAMES, watch: Callable[[Any], Callable[[], None]] | None = None
           ) -> dict[str, Any]:  # fmt: skip
    """Replay a recorded session headless; returns frames, commands, the state hashes and ``match``.

    Each command is applied exactly as the server applied it (the same method function,
    between the same two steps); an error that differs from the recorded one is counted
    in ``diverged``. ``progress(frame, last_frame)`` is called every :data:`PROGRESS_FRAMES`
    frames stepped. A replay naming a frame past ``max_frames`` is refused before it starts.
    ``watch(scene)`` is called before the first step; what it returns is called after every
    step (a motion recorder's capture: ``twig export`` of a replay).
    """
    header, commands, end = read_replay(path, max_frames)
    with tempfile.TemporaryDirectory(prefix="twig-replay-") as tmp:
        scene = _load_scene(header, Path(tmp))
    server = Server(scene, autonomous=bool(header.get("autonomous", True)), log=log or (lambda text: None))
    final = end["end"] if end else (commands[-1]["frame"] if commands else 0)

    after_step = watch(scene) if watch is not None else None

    def step_to(frame: int) -> None:
        while scene.frame < frame:  # in chunks, to report progress (stepping in chunks changes nothing)
            if after_step is None:
                scene.step(min(PROGRESS_FRAMES, frame - scene.frame))
            else:
                for _ in range(min(PROGRESS_FRAMES, frame - scene.frame)):
                    scene.step()
                    after_step()
            if progress is not None:
                progress(scene.frame, final)

    def unknown(name: str) -> ReplayError:
        return ReplayError(f"unknown method '{name}' in the replay file")

    def applied(item: dict[str, Any], error: str | None) -> None:
        if progress is not None:
            progress(scene.frame, final)

    try:
        diverged = apply_records(server, commands, step_to, unknown, applied)  # read_replay checked the order
        step_to(final)
        state_hash = scene.state_hash()
        recorded = end.get("state_hash") if end else None
        return {
            "scene": scene.name,
            "frames": scene.frame,
            "commands": len(commands),
            "diverged": diverged,
            "state_hash": state_hash,
            "recorded_state_hash": recorded,
            "match": recorded == state_hash and diverged == 0,
        }
    finally:
        scene.close()
