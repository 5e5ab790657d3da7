"""Headless runs with a physics health report (``twig run --report json``)."""

from __future__ import annotations

import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

from twig_ecs.clock import FixedStepClock
from twig_ecs.metrics import StoryRecorder
from twig_ecs.progress import Progress
from twig_ecs.scene import Scene
from twig_ecs.snapshot import save as save_snapshot
from twig_ecs.soak import Health, SoakLimits


def run_with_report(source: str | Path, seconds: float, seed: int = 0, content: tuple | list = (),
                    progress: bool = False, trace: str | Path | None = None,
                    plot: str | Path | None = None, parameters: dict | None = None,
                    limits: SoakLimits | None = None, scene: Scene | None = None,
                    save: str | Path | None = None) -> dict:  # fmt: skip
    """Load a scene, run it for ``seconds`` and measure it at every step.

    Returns a JSON-ready dict: scene, seconds, frames, step_ms {median, p95},
    max_link_error (largest |len-rest|/rest), max_penetration_m (deepest capsule
    overlap left after a step), min_node_y, max_speed_m_s, max_kinetic_energy_j, nan,
    state_hash and event counts; with characters, also per-character metrics
    (:mod:`twig_ecs.metrics`). ``trace`` writes a per-step CSV, ``plot`` a PNG of
    distance to caregiver and anxiety over time. ``limits`` (a soak): the run stops at
    the first limit crossed and the report's ``violation`` says where (else None).
    ``scene``: run this already loaded scene (a restored snapshot) instead of ``source``;
    ``seconds`` then counts from its current time. ``save``: write a snapshot at the end.
    """
    if scene is None:
        scene = Scene.load(source, seed=seed, content=content, **(parameters or {}))
    try:
        recorder = StoryRecorder(scene, trace=bool(trace or plot))
        report = _measure(scene, seconds, progress, recorder, limits)
        if scene.state.characters.count:
            report.update(recorder.report())
        if trace:
            recorder.write_trace(trace)
        if plot:
            recorder.plot(plot)
        if save:
            save_snapshot(scene, save)
        return report
    finally:
        scene.close()


def _measure(
    scene: Scene, seconds: float, progress: bool, recorder=None, limits: SoakLimits | None = None
) -> dict:
    frames = FixedStepClock(scene.dt).steps_for(seconds)
    shown = Progress(sys.stderr, scene.name) if progress else None  # a line now and then after 2 s
    step_ms = np.empty(frames)
    health = Health(scene, limits)
    scene.step(0)  # install systems and compile kernels outside the timings
    f = -1
    for f in range(frames):
        t0 = time.perf_counter()
        scene.step()
        step_ms[f] = (time.perf_counter() - t0) * 1000.0
        if recorder is not None:
            recorder.step()
        health.update()
        if health.nan or health.violation is not None:
            break
        if shown is not None:
            shown(f + 1, frames)
    if shown is not None:
        shown.done()
    done = step_ms[: f + 1]
    report = {
        "scene": scene.name,
        "seconds": round(scene.time, 6),
        "frames": scene.frame,
        "step_ms": {
            "median": float(np.median(done)) if len(done) else 0.0,
            "p95": float(np.percentile(done, 95)) if len(done) else 0.0,
        },
        **health.figures(),
        "state_hash": scene.state_hash(),
        "events": dict(sorted(scene.event_counts.items())),
    }
    if limits is not None:
        report["limits"] = asdict(limits)
        report["violation"] = asdict(health.violation) if health.violation else None
        if health.violation:
            report["violation"]["message"] = health.violation.message()
    return report
