"""``twig play`` and ``twig render``: the graphics subcommands of the ``twig`` command line."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable

from twig_ecs.argtypes import seconds_number


def register_commands(subparsers, add_scene_args: Callable[..., None]) -> None:
    """Add ``play`` and ``render`` to the ``twig`` parser's subcommands."""
    p = subparsers.add_parser("play", help="open a window and play a scene (default: schoolyard)")
    add_scene_args(p, scene_default="schoolyard")
    p.add_argument("--size", default="1280x720", metavar="WxH", help="window size (default 1280x720)")
    p.add_argument("--camera", default="action", metavar="SPEC",
                   help="action (default: the characters, a third of the picture high, followed), auto (the "
                   "whole scene), follow:NAME, orbit:YAW,PITCH[,DIST] or EX,EY,EZ[@TX,TY,TZ]")  # fmt: skip
    p.add_argument("--paused", action="store_true", help="start paused")
    p.add_argument("--frames", type=int, default=None, metavar="N",
                   help="quit after N drawn frames (for scripted checks)")  # fmt: skip
    p.add_argument("--headless", action="store_true",
                   help="use an invisible EGL window (no display needed; for scripted checks)")  # fmt: skip
    p.add_argument("--screenshot-dir", default=".", metavar="DIR", help="where F12 writes PNGs (default .)")
    p.set_defaults(func=cmd_play)

    p = subparsers.add_parser("render", help="run a scene offscreen and write a PNG, GIF or MP4")
    add_scene_args(p)
    p.add_argument("--seconds", type=seconds_number, default=None,
                   help="simulated seconds (default 2); with --at: a GIF/MP4's length from it")  # fmt: skip
    p.add_argument("-o", "--output", required=True, metavar="FILE",
                   help="output file: .png (last frame), .gif or .mp4 (every frame)")  # fmt: skip
    p.add_argument("--at", metavar="KIND[:N]", default=None,
                   help="a close-up of the N-th (default first) kick, push, hug, fight (scuffle) or grab: "
                   "run until it happens, frame who is involved")  # fmt: skip
    p.add_argument("--within", type=seconds_number, default=120.0, metavar="SECONDS",
                   help="with --at: how long to look for the moment (default 120 simulated s)")  # fmt: skip
    p.add_argument("--size", default="1280x720", metavar="WxH", help="image size (default 1280x720)")
    p.add_argument("--fps", type=float, default=None,
                   help="frames per second of a GIF/MP4 (default 15 for GIF, 30 for MP4)")  # fmt: skip
    p.add_argument("--camera", default=None, metavar="SPEC",
                   help="action (default: the characters, the tallest a third of the picture high; "
                   "with --at: close on those involved), auto "
                   "(the whole scene), follow:NAME, "
                   "orbit:YAW,PITCH[,DIST] or EX,EY,EZ[@TX,TY,TZ] (eye and target, m)")  # fmt: skip
    p.set_defaults(func=cmd_render)


def cmd_render(args: argparse.Namespace) -> int:
    """Render a scene offscreen to a file."""
    from twig_ecs import Scene
    from twig_ecs.graphics.camera import CameraSpec
    from twig_ecs.graphics.closeup import MomentSpec
    from twig_ecs.graphics.offscreen import RenderError, check_output, parse_size, render_scene

    size = parse_size(args.size)
    output = check_output(args.output)
    camera = None if args.camera is None else CameraSpec.parse(args.camera)
    moment = None if args.at is None else MomentSpec.parse(args.at)
    if moment is not None and output.suffix.lower() == ".png" and args.seconds is not None:
        raise RenderError(f"--at {args.at} with a .png shows the moment itself, so --seconds has no use "
                          "there; drop it, or write a .gif or .mp4 of --seconds from the moment")  # fmt: skip
    seconds = 2.0 if args.seconds is None else args.seconds
    scene = Scene.load(args.scene, seed=args.seed, content=args.content, **args.parameters)
    try:
        if moment is None:
            result = render_scene(scene, seconds, output, size=size, fps=args.fps, camera=camera or "action")
        else:
            result = _render_moment(scene, moment, args, output, size, seconds, camera)
    finally:
        scene.close()
    kind = "frame" if result.frames == 1 else "frames"
    print(f"wrote {result.path} ({result.size[0]}x{result.size[1]}, {result.frames} {kind}, "
          f"{result.ms_per_frame:.1f} ms/frame render)")  # fmt: skip
    return 0


def _render_moment(scene, moment, args, output, size, seconds, camera):
    """Run to the moment ``--at`` names, say what was found, and render it (or a clip from it)."""
    from twig_ecs.graphics.closeup import camera_text, closeup_camera, find_moment
    from twig_ecs.graphics.offscreen import render_scene
    from twig_ecs.progress import Progress
    from twig_ecs.systems.behaviours.play import yard_of

    progress = Progress(sys.stderr, f"looking for {moment}")
    try:
        found = find_moment(scene, moment, args.within, progress)
    finally:
        progress.done()
    if camera is None:
        camera = closeup_camera(scene, found.names, size[0] / size[1], yard_of(scene))
        how = f"camera {camera_text(camera)}"
    else:
        how = f"camera {args.camera}"
    print(f"{moment.kind} {moment.number} at {found.time:.2f} s: {' and '.join(found.names)} ({how})")
    if output.suffix.lower() == ".png":
        return render_scene(scene, found.time, output, size=size, fps=args.fps, camera=camera)
    return render_scene(scene, seconds, output, size=size, fps=args.fps, camera=camera, start=found.time)


def cmd_play(args: argparse.Namespace) -> int:
    """Open the interactive window."""
    from twig_ecs.graphics.camera import CameraSpec
    from twig_ecs.graphics.offscreen import parse_size

    size = parse_size(args.size)
    camera = CameraSpec.parse(args.camera)
    from twig_ecs.graphics.app import play

    frames = play(args.scene, seed=args.seed, content=args.content, size=size, camera=camera,
                  paused=args.paused, max_frames=args.frames, headless=args.headless,
                  screenshot_dir=args.screenshot_dir, parameters=args.parameters)  # fmt: skip
    if args.frames is not None:
        print(f"played {frames} frames", file=sys.stderr)
    return 0
