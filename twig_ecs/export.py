"""``twig export``: run a scene (or a snapshot) and write its motion as glTF (.glb) or BVH.

:func:`export_motion` records a run (:class:`~twig_ecs.motion.MotionRecorder`), fits the
humanoid skeleton to every figure (:func:`~twig_ecs.skeleton.fit`) and writes a .glb of
the whole scene (:mod:`twig_ecs.gltfwriter`) or BVH files of its figures
(:mod:`twig_ecs.bvhwriter`). docs/export.md says what maps to what.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from twig_ecs.argtypes import positive_seconds
from twig_ecs.errors import TwigError
from twig_ecs.motion import FRAME_RATES, MotionRecorder
from twig_ecs.skeleton import Skeleton, fit

FORMATS = (".glb", ".bvh")


class ExportError(TwigError):
    """An export asked for something it cannot write (an extension, a character)."""


def check_output(path: str | Path) -> str:
    """The output's format (``.glb`` or ``.bvh``) from its extension, or ExportError."""
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise ExportError(
            f"cannot export to '{path}': give a file ending in .glb (glTF 2.0 binary) "
            "or .bvh (BVH motion of the characters)"
        )
    folder = Path(path).parent
    if not folder.is_dir():
        raise ExportError(f"cannot export to '{path}': there is no folder '{folder}' (make it first)")
    return suffix


def skeletons(recorder: MotionRecorder, names: list[str] | None = None) -> dict[str, Skeleton]:
    """The fitted skeleton of each figure recorded (or of those ``names``)."""
    out = {}
    for name in names if names is not None else recorder.figures():
        track = recorder.tracks[name]
        out[name] = fit(track.node_names, track.rest, track.positions, track.height, track.face_directions)
    return out


def bvh_paths(path: str | Path, figures: list[str]) -> list[Path]:
    """Where the BVH of each figure goes: ``path`` itself for one, ``stem-NAME.bvh`` beside it for more."""
    path = Path(path)
    if len(figures) == 1:
        return [path]
    return [path.with_name(f"{path.stem}-{name}{path.suffix}") for name in figures]


def write(recorder: MotionRecorder, path: str | Path, character: str | None = None) -> list[Path]:
    """Write a recording to ``path`` (.glb or .bvh); returns the files written.

    ``character``: only this figure (a .bvh gets one file; a .glb keeps every body that is
    not a figure - props, the ball - and leaves the other figures out).
    """
    try:
        return _write(recorder, path, character)
    except OSError as exc:  # a full disk, a folder one may not write in
        raise ExportError(f"cannot write '{exc.filename or path}': {exc.strerror or exc}") from None


def chosen_figures(recorder: MotionRecorder, path: str | Path, character: str | None = None) -> list[str]:
    """The figures an export to ``path`` writes, or ExportError when it can write nothing asked of it.

    Known as soon as the recorder is made, so :func:`export_motion` asks before it runs.
    """
    fmt = check_output(path)
    if not recorder.tracks:
        raise ExportError(f"'{recorder.scene.name}' has no bodies: there is no motion to export")
    figures = recorder.figures()
    if character is not None:
        if character not in figures:
            known = ", ".join(figures) or "none in this scene"
            raise ExportError(f"'{character}' is not a character or ragdoll of this scene (those: {known})")
        figures = [character]
    if fmt == ".bvh" and not figures:
        raise ExportError("this scene has no character or ragdoll to write as BVH; export a .glb instead")
    return figures


def _write(recorder: MotionRecorder, path: str | Path, character: str | None) -> list[Path]:
    figures = chosen_figures(recorder, path, character)
    if check_output(path) == ".bvh":
        from twig_ecs.bvhwriter import write_bvh

        fitted = skeletons(recorder, figures)
        return [
            write_bvh(fitted[name], out, recorder.fps)
            for name, out in zip(figures, bvh_paths(path, figures), strict=True)
        ]
    from twig_ecs.gltfwriter import write_glb

    tracks = [
        t for name, t in recorder.tracks.items() if character is None or not t.is_figure or name == character
    ]
    return [write_glb(tracks, skeletons(recorder, figures), path, recorder.fps)]


def is_snapshot(source: str | Path) -> bool:
    """Is ``source`` a snapshot file (``twig run --save``), told by its first bytes?"""
    from twig_ecs.snapshot import MAGIC

    candidate = Path(source)
    if not candidate.is_file():
        return False
    with candidate.open("rb") as f:
        return f.read(len(MAGIC)) == MAGIC


def is_replay(source: str | Path) -> bool:
    """Is ``source`` a recorded session (``twig serve --record``), told by its first bytes?"""
    candidate = Path(source)
    if not candidate.is_file():
        return False
    with candidate.open("rb") as f:
        return f.read(16).startswith(b'{"twig_replay"')


def export_replay(path: str | Path, out: str | Path, fps: int = 30, character: str | None = None,
                  progress: bool = False) -> dict:  # fmt: skip
    """Replay a recorded session (as ``twig run --replay``) and write its motion to ``out``:
    the bodies there at its start, for its whole length."""
    from twig_ecs.progress import Progress
    from twig_ecs.server.replay import replay

    check_output(out)
    started = time.perf_counter()
    box: dict = {}

    def watch(scene):
        box["recorder"] = recorder = MotionRecorder(scene, fps=fps)
        chosen_figures(recorder, out, character)  # a wrong --character: say so before the run
        box["ready"] = time.perf_counter()
        return recorder.capture

    shown = Progress(sys.stderr, f"{Path(path).name}: replaying") if progress else None
    try:
        result = replay(path, progress=shown, watch=watch)
    finally:
        if shown is not None:
            shown.done()
    recorder = box["recorder"]
    recorded = time.perf_counter()
    files = write(recorder, out, character)
    return _report(result["scene"], recorder, files, (started, box["ready"], recorded, time.perf_counter()))


def _report(scene: str, recorder: MotionRecorder, files: list[Path], times: tuple[float, ...]) -> dict:
    """What an export did: the scene, frames, figures and files, and its timings from
    ``times`` (started, ready to record, recorded, written: perf_counter seconds)."""
    started, ready, recorded, done = times
    return {
        "scene": scene,
        "frames": recorder.frame_count,
        "fps": recorder.fps,
        "figures": recorder.figures(),
        "files": [str(f) for f in files],
        "load_s": ready - started,
        "record_s": recorded - ready,
        "write_s": done - recorded,
    }


def _open(source: str, seed: int, content, parameters: dict):
    """A scene from a scene file or name, or from a snapshot file."""
    from twig_ecs.scene import Scene

    if is_snapshot(source):
        from twig_ecs.snapshot import load

        return load(source)
    return Scene.load(source, seed=seed, content=content, **parameters)


def export_motion(
    source: str,
    out: str | Path,
    seconds: float,
    seed: int = 0,
    fps: int = 30,
    character: str | None = None,
    content=(),
    parameters: dict | None = None,
    progress: bool = False,
) -> dict:
    """Run ``source`` for ``seconds``, write its motion to ``out``; returns what was done and its timings."""
    check_output(out)
    started = time.perf_counter()
    scene = _open(source, seed, content, parameters or {})
    try:
        scene.step(0)  # compile kernels and install systems before the clock starts
        ready = time.perf_counter()
        recorder = MotionRecorder(scene, fps=fps)
        chosen_figures(recorder, out, character)  # a wrong --character: say so before the run
        recorder.run(seconds, progress=progress)
        recorded = time.perf_counter()
        files = write(recorder, out, character)
        done = time.perf_counter()
    finally:
        scene.close()
    return _report(scene.name, recorder, files, (started, ready, recorded, done))


def cmd_export(args: argparse.Namespace) -> int:
    """``twig export``: run a scene, snapshot or replay and write its motion as .glb or .bvh."""
    from twig_ecs import kernels

    check_output(args.output)  # before a first run's kernels compile, which takes minutes
    if kernels.needs_build():  # a first run: compile them up front, saying so (as `twig run` does)
        source = "schoolyard" if is_snapshot(args.scene) else args.scene  # a snapshot: the usual kernels
        kernels.prepare(source, seed=args.seed, content=args.content, parameters=args.parameters)
    if is_replay(args.scene):  # its own length, scene and seed
        report = export_replay(args.scene, args.output, fps=args.fps, character=args.character, progress=True)
    else:
        report = export_motion(
            args.scene,
            args.output,
            args.seconds,
            seed=args.seed,
            fps=args.fps,
            character=args.character,
            content=args.content,
            parameters=args.parameters,
            progress=True,
        )
    print(
        f"{report['scene']}: {report['frames']} frames at {report['fps']} fps "
        f"(recorded in {report['record_s']:.1f} s, written in {report['write_s']:.1f} s) -> "
        f"{', '.join(report['files'])}"
    )
    return 0


def register_commands(sub, add_scene_args) -> None:
    """Add ``twig export`` to the ``twig`` parser's subcommands."""
    p = sub.add_parser(
        "export", help="run a scene, snapshot or replay; write its motion as .glb or .bvh (docs/export.md)"
    )
    add_scene_args(p)
    p.add_argument(
        "-o",
        "--output",
        required=True,
        metavar="FILE",
        help="out.glb (every body: skinned characters, animated props) or out.bvh (one per character)",
    )
    p.add_argument("--seconds", type=positive_seconds, default=10.0, help="simulated seconds (default 10)")
    p.add_argument("--fps", type=int, choices=FRAME_RATES, default=30, help="frames a second (default 30)")
    p.add_argument("--character", metavar="NAME", help="only this character (or ragdoll)")
    p.set_defaults(func=cmd_export)
