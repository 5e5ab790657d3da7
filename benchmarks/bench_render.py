"""Offscreen render time per frame (median ms) at 1280x720: the schoolyard and 100 characters.

Run: ``python benchmarks/bench_render.py [--frames N] [--size WxH]``. Each frame is one
simulation step (not timed) and one render; "draw" is drawing until the GPU finishes,
"draw+read" adds reading the image back (what ``twig render`` pays per frame).
"""

from __future__ import annotations

import argparse
import statistics
import time

from twig_ecs import Scene
from twig_ecs.graphics.camera import CameraSpec
from twig_ecs.graphics.offscreen import OffscreenRenderer, parse_size


def crowd(count: int = 100) -> Scene:
    """``count`` humanoids on a grid, 1.5 m apart, facing different ways."""
    scene = Scene.load("empty")
    side = int(count**0.5 + 0.999)
    for k in range(count):
        x, z = (k % side - side / 2) * 1.5, (k // side - side / 2) * 1.5
        scene.spawn("humanoid", name=f"h{k}", position=(x, 0.0, z), facing=(k * 37) % 360)
    return scene


def measure(off: OffscreenRenderer, scene: Scene, size: tuple[int, int], frames: int) -> dict[str, float]:
    camera = CameraSpec().make(scene, size[0] / size[1])
    off.render(scene, camera, size)  # compile shaders, size buffers
    draw, read = [], []
    for _ in range(frames):
        scene.step()
        t0 = time.perf_counter()
        off.renderer.render(scene, camera, size)
        off.ctx.finish()
        t1 = time.perf_counter()
        off.renderer.read_pixels()
        t2 = time.perf_counter()
        draw.append((t1 - t0) * 1000.0)
        read.append((t2 - t0) * 1000.0)
    state = scene.state
    return {
        "links": int(state.links.count),
        "draw": statistics.median(draw),
        "read": statistics.median(read),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--size", default="1280x720")
    args = parser.parse_args()
    size = parse_size(args.size)
    scenes = [("schoolyard", lambda: Scene.load("schoolyard")), ("100 characters", crowd)]
    with OffscreenRenderer() as off:
        print(f"offscreen {size[0]}x{size[1]}, {args.frames} frames, {off.ctx.info['GL_RENDERER']}")
        print(f"{'scene':<16} {'links':>6} {'draw ms':>9} {'draw+read ms':>13}")
        for name, make in scenes:
            scene = make()
            try:
                r = measure(off, scene, size, args.frames)
            finally:
                scene.close()
            print(f"{name:<16} {r['links']:>6} {r['draw']:>9.2f} {r['read']:>13.2f}")


if __name__ == "__main__":
    main()
