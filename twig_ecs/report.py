"""Headless runs with a physics health report (``twig run --report json``)."""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

from twig_ecs.scene import Scene


def run_with_report(source: str | Path, seconds: float, seed: int = 0, content: tuple | list = (),
                    progress: bool = False, trace: str | Path | None = None,
                    plot: str | Path | None = None, parameters: dict | None = None) -> dict:  # fmt: skip
    """Load a scene, run it for ``seconds`` and measure it at every step.

    Returns a JSON-ready dict: scene, seconds, frames, step_ms {median, p95},
    max_link_error (largest |len-rest|/rest), max_penetration_m (deepest capsule
    overlap left after a step), min_node_y, nan, state_hash and event counts; with
    characters, also per-character metrics (:mod:`twig_ecs.metrics`). ``trace`` writes a
    per-step CSV, ``plot`` a PNG of distance to caregiver and anxiety over time.
    """
    from twig_ecs.metrics import StoryRecorder

    scene = Scene.load(source, seed=seed, content=content, **(parameters or {}))
    try:
        recorder = StoryRecorder(scene, trace=bool(trace or plot))
        report = _measure(scene, seconds, progress, recorder)
        if scene.state.characters.count:
            report.update(recorder.report())
        if trace:
            recorder.write_trace(trace)
        if plot:
            recorder.plot(plot)
        return report
    finally:
        scene.close()


def _measure(scene: Scene, seconds: float, progress: bool, recorder=None) -> dict:
    frames = int(round(seconds / scene.dt))
    step_ms = np.empty(frames)
    max_link_error = 0.0
    max_penetration = 0.0
    min_y = math.inf
    nan = False
    scene.step(0)  # install systems and compile kernels outside the timings
    nodes = scene.state.nodes
    for f in range(frames):
        t0 = time.perf_counter()
        scene.step()
        step_ms[f] = (time.perf_counter() - t0) * 1000.0
        if recorder is not None:
            recorder.step()
        pos = nodes.pos[: nodes.count]
        if not np.isfinite(pos).all():
            nan = True
            break
        errors = scene.state.link_errors()
        if len(errors):
            max_link_error = max(max_link_error, float(errors.max()))
        max_penetration = max(max_penetration, float(scene.state.stats[0]))
        if len(pos):
            min_y = min(min_y, float(pos[:, 1].min()))
        if progress and f % 60 == 0:
            print(f"\r{scene.name}: {f / 60:6.1f} / {seconds:.1f} s", end="", file=sys.stderr, flush=True)
    if progress:
        print(file=sys.stderr)
    done = step_ms[: f + 1] if frames else step_ms
    return {
        "scene": scene.name,
        "seconds": round(scene.time, 6),
        "frames": scene.frame,
        "step_ms": {
            "median": float(np.median(done)) if len(done) else 0.0,
            "p95": float(np.percentile(done, 95)) if len(done) else 0.0,
        },
        "max_link_error": max_link_error,
        "max_penetration_m": max_penetration,
        "min_node_y": min_y if math.isfinite(min_y) else None,
        "nan": nan,
        "state_hash": scene.state_hash(),
        "events": dict(sorted(scene.event_counts.items())),
    }
