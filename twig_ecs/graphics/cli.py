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
    p.add_argument("--seconds", type=seconds_number, default=2.0, help="simulated seconds (default 2)")
    p.add_argument("-o", "--output", required=True, metavar="FILE",
                   help="output file: .png (last frame), .gif or .mp4 (every frame)")  # fmt: skip
    p.add_argument("--size", default="1280x720", metavar="WxH", help="image size (default 1280x720)")
    p.add_argument("--fps", type=float, default=None,
                   help="frames per second of a GIF/MP4 (default 15 for GIF, 30 for MP4)")  # fmt: skip
    p.add_argument("--camera", default="action", metavar="SPEC",
                   help="action (default: the characters, the tallest a third of the picture high), auto "
                   "(the whole scene), follow:NAME, "
                   "orbit:YAW,PITCH[,DIST] or EX,EY,EZ[@TX,TY,TZ] (eye and target, m)")  # fmt: skip
    p.set_defaults(func=cmd_render)


def cmd_render(args: argparse.Namespace) -> int:
    """Render a scene offscreen to a file."""
    from twig_ecs import Scene
    from twig_ecs.graphics.camera import CameraSpec
    from twig_ecs.graphics.offscreen import check_output, parse_size, render_scene

    size = parse_size(args.size)
    check_output(args.output)
    camera = CameraSpec.parse(args.camera)
    scene = Scene.load(args.scene, seed=args.seed, content=args.content, **args.parameters)
    try:
        result = render_scene(scene, args.seconds, args.output, size=size, fps=args.fps, camera=camera)
    finally:
        scene.close()
    kind = "frame" if result.frames == 1 else "frames"
    print(f"wrote {result.path} ({result.size[0]}x{result.size[1]}, {result.frames} {kind}, "
          f"{result.ms_per_frame:.1f} ms/frame render)")  # fmt: skip
    return 0


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
