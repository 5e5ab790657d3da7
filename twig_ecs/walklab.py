"""The walk lab (``twig walklab``): gait figures per body size and speed, beside a person's.

Everything is measured through the public API - node positions and foot locks of a
character handle, step by step - so the tests use the same helpers
(:func:`record`, :func:`walk_figures`, :func:`torso_pitch`, :func:`foot_moves`).
Reference figures are those of docs/locomotion.md (BELIEVABILITY.md: walking, dynamic
similarity, turning, standing).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: Nodes a track records.
TRACKED = ("pelvis", "neck", "l_hip", "r_hip", "l_knee", "r_knee", "l_foot", "r_foot",
           "l_shoulder", "r_shoulder", "l_elbow", "r_elbow", "l_hand", "r_hand")  # fmt: skip
#: The side-view contact sheets ``--sheet`` writes: (file suffix, what, height m, speed m/s).
SHEETS = (("", "walk", 1.75, 1.2), ("-run", "run", 1.75, 2.5))
#: Body heights (m) the lab measures: a small child, a big child, an adult.
SIZES = (1.05, 1.35, 1.75)
#: Speeds (m/s) the lab asks each size for: walks, and runs (2.4 m/s: Froude 0.6-1.1; 3.0 m/s:
#: an adult's brisk run, Froude 1.05, past the 1.05 m child's top speed of Froude 1.5, 2.8 m/s).
SPEEDS = (0.8, 1.0, 1.2, 1.6, 2.4, 3.0)


@dataclass
class Track:
    """Per-step node positions (steps, node, 3) and foot locks (steps, 2) of one character."""

    dt: float
    pos: dict[str, np.ndarray]
    locked: np.ndarray  # bool (steps, 2): left, right foot planted
    stand_height: float
    radius: float  # foot node radius (m)
    heading: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))


def record(handle, seconds: float) -> Track:
    """Step ``handle``'s scene for ``seconds``, recording the tracked nodes and foot locks."""
    scene = handle.scene
    n = int(round(seconds / scene.dt))
    pos = {name: np.zeros((n, 3)) for name in TRACKED}
    locked = np.zeros((n, 2), dtype=bool)
    for k in range(n):
        scene.step()
        for name in TRACKED:
            pos[name][k] = handle.node(name)
        locked[k] = handle.is_locked("l_foot"), handle.is_locked("r_foot")
    radius = float(scene.state.nodes.radius[handle.node_row("l_foot")])
    walk = handle.walk_velocity
    norm = float(np.linalg.norm(walk))
    heading = walk / norm if norm > 1e-9 else np.array([0.0, 0.0, 1.0])
    return Track(scene.dt, pos, locked, handle.stand_height, radius, heading)


def knee_flexion(hip: np.ndarray, knee: np.ndarray, foot: np.ndarray) -> np.ndarray:
    """Knee flexion (degrees, 0 = straight) from hip-knee-foot positions (arrays of points)."""
    a = hip - knee
    b = foot - knee
    cos = np.sum(a * b, axis=-1) / (np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1) + 1e-12)
    return 180.0 - np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def torso_pitch(track: Track) -> np.ndarray:
    """Torso lean from the vertical (degrees) per step: the pelvis-to-neck line."""
    v = track.pos["neck"] - track.pos["pelvis"]
    horizontal = np.linalg.norm(v[:, [0, 2]], axis=1)
    return np.degrees(np.arctan2(horizontal, v[:, 1]))


def elbow_flexion(track: Track) -> np.ndarray:
    """Elbow flexion (degrees, 0 = straight) per step, left and right: (steps, 2)."""
    return np.stack([knee_flexion(track.pos[f"{s}_shoulder"], track.pos[f"{s}_elbow"], track.pos[f"{s}_hand"])
                     for s in "lr"], axis=1)  # fmt: skip


def arm_phase(track: Track) -> float:
    """How the arms swing against the legs: the correlation of each hand's and the same-side
    foot's lead over the pelvis along the walk, averaged over both sides (-1: the hand
    forwards as its own foot goes back - opposite the legs, as a person's; NaN: no swing)."""
    out = []
    for s in "lr":
        hand = (track.pos[f"{s}_hand"] - track.pos["pelvis"]) @ track.heading
        foot = (track.pos[f"{s}_foot"] - track.pos["pelvis"]) @ track.heading
        if hand.std() < 1e-9 or foot.std() < 1e-9:
            return math.nan
        out.append(float(np.corrcoef(hand, foot)[0, 1]))
    return float(np.mean(out))


def touchdowns(track: Track) -> list[tuple[int, int]]:
    """(step, foot) of every touchdown: a foot becoming planted."""
    out = []
    for f in range(2):
        col = track.locked[:, f]
        for k in np.nonzero(col[1:] & ~col[:-1])[0]:
            out.append((int(k) + 1, f))
    return sorted(out)


def foot_moves(track: Track) -> int:
    """How many times a planted foot came up (a step taken)."""
    return int(np.sum(track.locked[:-1] & ~track.locked[1:]))


def walk_figures(track: Track) -> dict[str, float]:
    """Cadence, step length, stance knee flexion, pelvis height, double support, foot lift;
    the elbows' median flexion, the arms' swing against the legs (:func:`arm_phase`) and the
    torso's median pitch."""
    downs = touchdowns(track)
    seconds = len(track.locked) * track.dt
    out: dict[str, float] = {}
    if len(downs) >= 2:
        span = (downs[-1][0] - downs[0][0]) * track.dt
        out["cadence"] = (len(downs) - 1) / span if span > 0 else math.nan
    else:
        out["cadence"] = 0.0
    # step length: along the walk, from one foot's touchdown to the other foot's next one
    feet = (track.pos["l_foot"], track.pos["r_foot"])
    lengths: list[float] = []
    by_foot: tuple[list[float], list[float]] = ([], [])  # steps ending on the left, on the right foot
    for (k0, f0), (k1, f1) in zip(downs, downs[1:], strict=False):
        if f0 != f1:
            lengths.append(float((feet[f1][k1] - feet[f0][k0]) @ track.heading))
            by_foot[f1].append(lengths[-1])
    out["step"] = float(np.median(lengths)) if lengths else 0.0
    # the same foot landing twice in a row (a foot that hung in the air and flew again)
    out["twice"] = float(sum(1 for (_, a), (_, b) in zip(downs, downs[1:], strict=False) if a == b))
    # left and right steps alike: the difference of their medians over their mean
    if by_foot[0] and by_foot[1]:
        left, right = float(np.median(by_foot[0])), float(np.median(by_foot[1]))
        out["step_lr"] = abs(left - right) / max(0.5 * (left + right), 1e-9)
    else:
        out["step_lr"] = math.nan
    # the pelvis's pace along the walk, frame by frame: its lowest and highest over its mean
    pace = np.diff(track.pos["pelvis"] @ track.heading) / track.dt
    mean = float(pace.mean()) if pace.size else 0.0
    out["pace_low"] = float(pace.min() / mean) if mean > 1e-6 else math.nan
    out["pace_high"] = float(pace.max() / mean) if mean > 1e-6 else math.nan
    flex = []
    for f, side in enumerate("lr"):
        angles = knee_flexion(track.pos[f"{side}_hip"], track.pos[f"{side}_knee"], feet[f])
        flex.append(angles[track.locked[:, f]])
    stance = np.concatenate(flex)
    out["knee"] = float(np.median(stance)) if stance.size else math.nan
    out["pelvis"] = float(track.pos["pelvis"][:, 1].mean() / track.stand_height)
    out["bob"] = float(np.ptp(track.pos["pelvis"][:, 1]))
    out["double"] = float(np.mean(track.locked[:, 0] & track.locked[:, 1]))
    out["flight"] = float(np.mean(~track.locked[:, 0] & ~track.locked[:, 1]))  # a run's both feet up
    # foot lift: the highest a foot's bottom gets between lifting off and landing
    lifts = []
    for f in range(2):
        col = track.locked[:, f]
        k = 0
        while k < len(col):
            if not col[k]:
                j = k
                while j < len(col) and not col[j]:
                    j += 1
                if k > 0 and j < len(col):  # a whole swing inside the window
                    lifts.append(float(feet[f][k:j, 1].max() - track.radius))
                k = j
            else:
                k += 1
    out["lift"] = float(np.median(lifts)) if lifts else 0.0
    # landing ahead of the hip: the foot's lead over its hip at touchdown
    ahead = [float((feet[f][k] - track.pos[("l_hip", "r_hip")[f]][k]) @ track.heading) for k, f in downs]
    out["ahead"] = float(np.median(ahead)) if ahead else 0.0
    out["speed"] = float((track.pos["pelvis"][-1] - track.pos["pelvis"][0]) @ track.heading / seconds)
    # what a viewer notices of the upper body: bent or straight arms, swung with or against the
    # legs, and the lean
    out["elbow"] = float(np.median(elbow_flexion(track)))
    out["arm_phase"] = arm_phase(track)
    out["pitch"] = float(np.median(torso_pitch(track)))
    return out


def stance_knees(track: Track) -> float:
    """Median knee flexion (degrees) of both legs over a track (standing: every frame)."""
    angles = [
        knee_flexion(track.pos[f"{s}_hip"], track.pos[f"{s}_knee"], track.pos[f"{s}_foot"]) for s in "lr"
    ]
    return float(np.median(np.concatenate(angles)))


def leg_length(handle) -> float:
    """Hip-knee plus knee-foot (m) as the body stands now."""
    hip, knee, foot = (handle.node(n) for n in ("l_hip", "l_knee", "l_foot"))
    return float(np.linalg.norm(hip - knee) + np.linalg.norm(knee - foot))


def _scene():
    from twig_ecs import Scene

    return Scene.load("empty")


def _walker(scene, name: str, height: float):
    """A ``height`` m character standing in ``scene`` after half a second to settle."""
    person = scene.spawn("humanoid", name=name, height=height, character=True)
    scene.run(0.5)
    return person


def measure_walk(height: float, speed: float, settle: float = 2.5, seconds: float = 5.0) -> dict[str, float]:
    """Figures of a ``height`` m character walking straight at ``speed`` m/s (after ``settle`` s)."""
    scene = _scene()
    try:
        person = _walker(scene, "walker", height)
        legs = leg_length(person)
        person.walk((0.0, 0.0, speed))
        scene.run(settle)
        figures = walk_figures(record(person, seconds))
        figures["froude"] = speed**2 / (9.81 * legs)
        figures["legs"] = legs
        return figures
    finally:
        scene.close()


def measure_stand(height: float, settle: float = 1.0, seconds: float = 2.0) -> dict[str, float]:
    """A ``height`` m character standing still: median knee flexion (degrees), pelvis height
    over its standing height, foot moves."""
    scene = _scene()
    try:
        person = _walker(scene, "stander", height)
        scene.run(settle)
        track = record(person, seconds)
        return {
            "knee": stance_knees(track),
            "pelvis": float(track.pos["pelvis"][:, 1].mean() / track.stand_height),
            "moves": float(foot_moves(track)),
        }
    finally:
        scene.close()


def measure_uturn(height: float, speed: float = 1.2) -> float:
    """Largest torso pitch (degrees) of a ``height`` m character turning back at ``speed``."""
    scene = _scene()
    try:
        person = _walker(scene, "turner", height)
        person.walk((0.0, 0.0, speed))
        scene.run(3.0)
        person.walk((0.0, 0.0, -speed))
        return float(torso_pitch(record(person, 4.0)).max())
    finally:
        scene.close()


#: Playground characters that stand in place and use their arms or eyes, and what they do.
IDLE = {"pointer": "points", "waver": "waves", "reacher": "reaches", "watcher": "watches"}


def measure_idle(seconds: float = 10.0, settle: float = 1.0) -> dict[str, int]:
    """Foot moves in ``seconds`` of each standing playground character (after ``settle`` s)."""
    from twig_ecs import Scene

    scene = Scene.load("playground")
    try:
        scene.run(settle)
        handles = {name: scene.entity(name) for name in IDLE}
        moves = dict.fromkeys(IDLE, 0)
        before = {name: (h.is_locked("l_foot"), h.is_locked("r_foot")) for name, h in handles.items()}
        for _ in range(int(round(seconds / scene.dt))):
            scene.step()
            for name, h in handles.items():
                now = (h.is_locked("l_foot"), h.is_locked("r_foot"))
                moves[name] += sum(1 for a, b in zip(before[name], now, strict=True) if a and not b)
                before[name] = now
        return moves
    finally:
        scene.close()


#: What a person does (BELIEVABILITY.md), by column: (low, high) or a note.
HUMAN = {
    "cadence": "adult 1.2 m/s: 1.8-2.0 /s; 1.05 m child 1.0 m/s: 2.5-3",
    "step": "adult 1.2 m/s: 0.65-0.75 m (~0.4 x height)",
    "knee": "stance 5-20 deg; standing 0-10",
    "pace": "pelvis pace through a step within +-20% of its mean; left and right steps within 5%",
    "pelvis": "close to standing (>= 0.9), bob 2-5 cm",
    "double": "~0.20 at a normal walk, less faster; none running",
    "flight": "0 walking; running 0.1-0.3 (both feet up)",
    "twice": "0 (feet take turns: no foot lands twice in a row)",
    "elbow": "walking nearly straight (~10-30 deg); running ~90",
    "arms": "swung opposite the legs (arm r, hand against same-side foot: near -1)",
    "pitch": "walking upright to a few deg forward; running 5-10 deg into the pace",
    "lift": "a few cm at the toe, visibly at the heel",
    "uturn": "upright: a few degrees (<= 30 here)",
    "idle": "0 (step only when balance needs it)",
}


def table(sizes=SIZES, speeds=SPEEDS) -> list[dict[str, float]]:
    """One row of walk figures per (size, speed) the lab runs."""
    rows = []
    for h in sizes:
        for v in speeds:
            row = measure_walk(h, v)
            row["height"], row["asked"] = h, v
            rows.append(row)
    return rows


def format_report(rows, uturns: dict[float, float], idle: dict[str, int],
                  standing: dict[float, float] | None = None) -> str:  # fmt: skip
    """The lab's printed report: walk table, U-turn pitch, standing knees and idle re-steps
    beside a person's."""
    lines = ["Walk (straight, level ground; medians over 5 s after 2.5 s to get going)", ""]
    head = (f"{'height':>6} {'asked':>5} {'got':>5} {'Fr':>5} {'steps/s':>7} {'step m':>6} {'step/L':>6} "
            f"{'knee':>5} {'pelvis':>6} {'bob cm':>6} {'double':>6} {'flight':>6} {'lift cm':>7} "
            f"{'ahead cm':>8} {'pace -%':>7} {'pace +%':>7} {'L/R %':>5} {'twice':>5} {'elbow':>5} "
            f"{'arm r':>5} {'pitch':>5}")  # fmt: skip
    lines += [head, "-" * len(head)]
    for r in rows:
        lines.append(
            f"{r['height']:6.2f} {r['asked']:5.2f} {r['speed']:5.2f} {r['froude']:5.2f} {r['cadence']:7.2f} "
            f"{r['step']:6.2f} {r['step'] / r['legs']:6.2f} {r['knee']:5.0f} {r['pelvis']:6.2f} "
            f"{100 * r['bob']:6.1f} {r['double']:6.2f} {r.get('flight', 0.0):6.2f} {100 * r['lift']:7.1f} "
            f"{100 * r['ahead']:8.1f} {100 * (1.0 - r.get('pace_low', 1.0)):7.0f} "
            f"{100 * (r.get('pace_high', 1.0) - 1.0):7.0f} {100 * r.get('step_lr', 0.0):5.1f} "
            f"{r.get('twice', 0.0):5.0f} {r.get('elbow', math.nan):5.0f} {r.get('arm_phase', math.nan):5.2f} "
            f"{r.get('pitch', math.nan):5.1f}"
        )
    lines += [
        "",
        "A person: " + "; ".join(f"{k}: {v}" for k, v in HUMAN.items() if k not in ("uturn", "idle")),
    ]
    lines += [
        "",
        "U-turn at 1.2 m/s, largest torso pitch (deg): "
        + ", ".join(f"{h:.2f} m: {p:.0f}" for h, p in uturns.items())
        + f"   (a person: {HUMAN['uturn']})",
    ]
    if standing:
        lines += ["Standing still, median knee flexion (deg): "
                  + ", ".join(f"{h:.2f} m: {k:.0f}" for h, k in standing.items())
                  + "   (a person: 0-10)"]  # fmt: skip
    lines += ["Foot moves in 10 s standing in the playground: "
              + ", ".join(f"{name} ({IDLE[name]}): {n}" for name, n in idle.items())
              + f"   (a person: {HUMAN['idle']})"]  # fmt: skip
    return "\n".join(lines)


def contact_sheet(output: str | Path, height: float = 1.75, speed: float = 1.2, frames: int = 12,
                  every: float = 0.1, size: tuple[int, int] = (320, 320),
                  columns: int = 6) -> Path:  # fmt: skip
    """A side-view contact sheet PNG of a ``height`` m character walking (or running) at
    ``speed`` m/s."""
    from twig_ecs.graphics.camera import OrbitCamera
    from twig_ecs.graphics.offscreen import check_output
    from twig_ecs.graphics.offscreen import contact_sheet as draw_sheet

    path = check_output(output)
    scene = _scene()
    try:
        person = _walker(scene, "walker", height)
        person.walk((0.0, 0.0, speed))
        scene.run(2.5)

        def side_view() -> OrbitCamera:
            target = person.position.copy()
            target[1] = 0.5 * height * 0.95
            # side view: the camera on the character's left (+x), level with its hips
            return OrbitCamera(target, yaw=90.0, pitch=5.0, distance=1.8 * height)

        return draw_sheet(scene, path, side_view, frames, every, size, columns)
    finally:
        scene.close()


def sheet_paths(sheet: str | Path) -> list[Path]:
    """Where ``--sheet FILE.png`` puts each of :data:`SHEETS`: the walk at FILE.png, the run
    beside it at FILE-run.png."""
    path = Path(sheet)
    return [path.with_name(path.stem + suffix + path.suffix) for suffix, *_ in SHEETS]


def write_sheets(sheet: str | Path) -> list[str]:
    """Draw the walk and run contact sheets (:data:`SHEETS`) next to ``sheet``; one report line each."""
    lines = []
    for path, (_, what, height, speed) in zip(sheet_paths(sheet), SHEETS, strict=True):
        drawn = contact_sheet(path, height=height, speed=speed)
        lines.append(
            f"Contact sheet, {what} (side view, {height:.2f} m at {speed:.1f} m/s, 0.1 s apart): {drawn}"
        )
    return lines


def run_lab(sheet: str | Path | None = None, sizes=SIZES, speeds=SPEEDS) -> str:
    """Measure everything and write the walk and run contact sheets where ``sheet`` says
    (none by default; :func:`sheet_paths`); returns the printed report."""
    rows = table(sizes, speeds)
    uturns = {h: measure_uturn(h) for h in sizes}
    standing = {h: measure_stand(h)["knee"] for h in sorted({*sizes, 1.2})}
    text = format_report(rows, uturns, measure_idle(), standing)
    if sheet:
        text += "\n" + "\n".join(write_sheets(sheet))
    return text


def register_commands(sub) -> None:
    """Add ``twig walklab`` to the CLI's subcommands."""
    p = sub.add_parser("walklab", help="measure the walk per body size and speed beside a person's")
    p.add_argument("--sheet", default=None, metavar="FILE.png",
                   help="also write side-view contact sheets: the walk to FILE.png, the run to "
                        "FILE-run.png (default: none)")  # fmt: skip
    p.set_defaults(func=lambda args: print(run_lab(args.sheet or None)) or 0)


def main(argv: list[str] | None = None) -> None:
    """Run the lab from ``python -m twig_ecs.walklab [--sheet FILE.png]`` (no file unless asked)."""
    import argparse

    parser = argparse.ArgumentParser(prog="python -m twig_ecs.walklab", description=__doc__.split("\n\n")[0])
    parser.add_argument("--sheet", default=None, metavar="FILE.png",
                        help="also write walk and run contact sheets (FILE.png, FILE-run.png)")  # fmt: skip
    print(run_lab(parser.parse_args(argv).sheet))


if __name__ == "__main__":
    main()
