"""Timing a scene step by step, split by system (medians: robust on a busy machine)."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable

import numpy as np

from twig_ecs.scene import Scene

#: How the schedule's systems are grouped in the summary table.
PHYSICS = ("integrate", "constrain", "collide", "sense")
CONTROLLERS = ("patrol", "gait", "gaze", "posture", "arms", "respiration")


def group_of(system: str) -> str:
    """'physics', 'control' (the low-level controllers) or 'behaviour' (the rest)."""
    if system in PHYSICS:
        return "physics"
    if system in CONTROLLERS:
        return "control"
    return "behaviour"


def summary(seconds: np.ndarray) -> dict:
    """Median and 95th percentile (ms) of step times in seconds."""
    ms = np.sort(seconds) * 1000.0
    return {"median_ms": float(np.median(ms)), "p95_ms": float(ms[int(0.95 * (len(ms) - 1))])}


def _share(choice, counted: tuple[int, int]) -> float:
    """The share of steps on more than one thread since ``counted`` (steps, threaded steps)."""
    steps = choice.steps - counted[0]
    return (choice.threaded - counted[1]) / steps if steps else 0.0


#: Steps each simulator takes in a row when two are compared: long enough that caches
#: are warm again after the other one ran, short enough that both meet the same load.
BLOCK = 10


def measure(scene: Scene, steps: int, warmup: int, progress: Callable[[int], None] | None = None,
            beside: Callable[[], float] | None = None) -> dict:  # fmt: skip
    """Step ``warmup`` times untimed, then ``steps`` timed steps; medians in ms.

    Returns median and 95th-percentile step time, the first (warm-up) step's seconds
    (``first_step_s``: set-up a scene does on its first step), the median of every system, the
    per-group medians (physics, behaviour, control: the median of each step's group
    sum), the scene's size and its thread choice (``threads``: see
    :meth:`~twig_ecs.threads.ThreadChoice.summary`; ``threaded_share`` of the timed steps
    only). ``beside`` (another simulator's timed step, returning
    seconds) takes turns with ours, ``BLOCK`` steps each, so both meet the same machine
    load - on a shared machine the only fair comparison; its summary is under
    ``"beside"``.
    """
    first = None
    for k in range(warmup):
        started = time.perf_counter()
        scene.step()
        if k == 0:  # activating the scene: installing its systems, the first broad phase, ...
            first = time.perf_counter() - started
        if beside is not None:
            beside()
    choice = scene.thread_choice
    counted = (choice.steps, choice.threaded)  # (the timed steps' share of threaded steps, below)
    times: dict[str, list[float]] = {}
    totals = np.empty(steps)
    other = np.empty(steps)
    for start in range(0, steps, BLOCK):
        block = range(start, min(steps, start + BLOCK))
        for i in block:
            totals[i] = scene.step_timed(times)
            if progress is not None:
                progress(i)
        if beside is not None:
            for i in block:
                other[i] = beside()
    systems = {name: statistics.median(t) * 1000.0 for name, t in times.items()}
    groups = {}
    for group in ("physics", "behaviour", "control"):
        members = [times[n] for n in times if group_of(n) == group]
        groups[group] = float(np.median(np.sum(members, axis=0)) * 1000.0) if members else 0.0
    state = scene.state
    positions = state.nodes.pos[: state.nodes.count]
    return (
        summary(totals)
        | {
            "groups_ms": groups,
            "systems_ms": systems,
            "characters": int(state.characters.count),
            "bodies": int(state.bodies.count),
            "nodes": int(state.nodes.count),
            "colliders": int(state.colliders.count),
            "candidate_pairs": int(state.n_pairs),
            "nan": bool(np.isnan(positions).any()),
            "threads": choice.summary() | {"threaded_share": _share(choice, counted)},
            "first_step_s": first,
        }
        | ({"beside": summary(other)} if beside is not None else {})
    )
