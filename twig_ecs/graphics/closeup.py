"""Close-ups of interactions: ``twig render SCENE --at hug`` finds the moment and frames it.

:func:`find_moment` runs a scene until the N-th moment of a kind that
:class:`~twig_ecs.interactions.InteractionRecorder` notes (a kick, a push, a hug, a fight,
a grab) and leaves the scene at that step. :func:`closeup_camera` then frames the
entities involved side by side, from the side where nothing else stands between them and
the eye (and inside the yard's fence, if there is one). Both come from the run itself, so
a close-up keeps showing its interaction when behaviour changes and the moment moves.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from twig_ecs.errors import TwigError
from twig_ecs.graphics.camera import CameraSpec, OrbitCamera
from twig_ecs.interactions import MOMENT_KINDS, InteractionRecorder, Moment
from twig_ecs.store import LINK_VISIBLE, NODE_SPHERE

#: Other names a moment's kind is known by (the docs call a fight a scuffle).
ALIASES = {"scuffle": "fight"}
#: The eye's height above the framed bodies' middle, in degrees: low, as a bystander sees them.
PITCH = 12.0
#: Room round the framed bodies across the picture (1.0: they touch the picture's edges) ...
MARGIN = 1.1
#: ... and above and below them: less, since the framed points already stand 5 cm out from
#: every part, and above a head and below the feet is only sky and ground. A lone upright
#: figure (a kicker and its ball) is framed by its height, and a straight-legged child is thin:
#: at 1.1 the big child's kick covered 3.9% of the picture.
MARGIN_UP = 1.02
#: Of a large body involved (a merry-go-round), only the parts this close (m) to a
#: character are framed: the bar in the hands, not the whole deck.
NEAR_PART = 0.8
#: Views tried either side of square-on to the line between the two involved (degrees).
TURNS = (0.0, 20.0, -20.0, 40.0, -40.0, 60.0, -60.0)
#: How close (m) the eye may come to the yard's fence.
FENCE_ROOM = 0.3


class CloseupError(TwigError):
    """A ``--at`` moment that cannot be understood or was not found in the run."""


@dataclass(frozen=True)
class MomentSpec:
    """What ``--at KIND[:N]`` asked for: the ``number``-th moment of ``kind`` (from 1)."""

    kind: str
    number: int = 1

    @classmethod
    def parse(cls, text: str) -> MomentSpec:
        """``"hug"`` -> the first hug; ``"kick:3"`` -> the third kick; ``"scuffle"`` -> a fight."""
        kind, _, count = text.strip().lower().partition(":")
        kind = ALIASES.get(kind, kind)
        known = ", ".join((*MOMENT_KINDS, *ALIASES))
        if kind not in MOMENT_KINDS:
            raise CloseupError(f"--at '{text}': unknown moment '{kind}'; use one of {known}, e.g. --at hug:2")
        number = 1
        if count:
            try:
                number = int(count)
            except ValueError:
                number = 0
            if number < 1:
                raise CloseupError(f"--at '{text}': '{count}' is not a count from 1 (e.g. --at {kind}:2)")
        return cls(kind, number)

    def __str__(self) -> str:
        return f"{self.kind}:{self.number}"


def find_moment(scene, spec: MomentSpec, within: float,
                progress: Callable[[int, int], None] | None = None) -> Moment:  # fmt: skip
    """Step ``scene`` until the ``spec.number``-th moment of ``spec.kind`` and return it; the
    scene is left at that step. Raises :class:`CloseupError` when ``within`` simulated
    seconds pass without it, naming the moments that did happen."""
    scene.step(0)  # install systems (a held thing is taken hold of) before watching
    recorder = InteractionRecorder(scene, moments_only=True)  # moments, not a report's figures
    last = scene.frame + max(1, math.ceil(within / scene.dt - 1e-6))
    while scene.frame < last:
        scene.step(1)
        recorder.step()
        found = [m for m in recorder.moments if m.kind == spec.kind]
        if len(found) >= spec.number:
            return found[spec.number - 1]
        if progress is not None:
            progress(scene.frame, last)
    seen = Counter(m.kind for m in recorder.moments)
    listed = ", ".join(f"{kind} x{seen[kind]}" for kind in MOMENT_KINDS if seen[kind]) or "none"
    have = seen[spec.kind]
    raise CloseupError(
        f"--at {spec}: '{scene.name}' has {have} {spec.kind} moment{'s' * (have != 1)} in its first "
        f"{within:g} s, not {spec.number} (moments seen: {listed}); look further with --within SECONDS, "
        "or try another --seed"
    )


def _framed_rows(scene, names: tuple[str, ...]) -> list[np.ndarray]:
    """Node rows of what a close-up of ``names`` shows, per entity: whole characters and
    small things, and of a large thing only the parts near the characters."""
    pos = scene.state.nodes.pos
    bodies = [scene.entity(n) for n in names]
    characters = [b for b in bodies if "head" in b.node_names]
    near_to = np.vstack([b.node_positions for b in characters]) if characters else None
    out = []
    for handle in bodies:
        rows = np.arange(handle._rows().start, handle._rows().stop)
        if handle not in characters and near_to is not None and np.ptp(pos[rows], axis=0).max() > 1.5:
            gaps = np.linalg.norm(pos[rows][:, None] - near_to[None], axis=2).min(axis=1)
            rows = rows[gaps <= NEAR_PART] if (gaps <= NEAR_PART).any() else rows[[int(np.argmin(gaps))]]
        out.append(rows)
    return out


def _segment_gaps(p1: np.ndarray, q1: np.ndarray, p2: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Distances (k, m) between segments p1q1 (k rows) and p2q2 (m rows; a point when p2 = q2)."""
    d1, d2 = (q1 - p1)[:, None, :], (q2 - p2)[None, :, :]
    r = p1[:, None, :] - p2[None, :, :]
    a = np.maximum((d1 * d1).sum(-1), 1e-12)
    e = (d2 * d2).sum(-1)
    b, c, f = (d1 * d2).sum(-1), (d1 * r).sum(-1), (d2 * r).sum(-1)
    # closest points of the two lines, then clamped to the segments (Ericson, 5.1.9)
    denom = a * e - b * b
    s = np.where(denom > 1e-12, np.clip((b * f - c * e) / np.where(denom > 1e-12, denom, 1.0), 0.0, 1.0), 0.0)
    t = np.where(e > 1e-12, (b * s + f) / np.maximum(e, 1e-12), 0.0)
    s = np.where(t < 0.0, np.clip(-c / a, 0.0, 1.0), np.where(t > 1.0, np.clip((b - c) / a, 0.0, 1.0), s))
    t = np.clip(t, 0.0, 1.0)
    gap = (p1[:, None, :] + s[..., None] * d1) - (p2[None, :, :] + t[..., None] * d2)
    return np.linalg.norm(gap, axis=-1)


@dataclass(frozen=True)
class _Shapes:
    """Every drawn capsule and sphere of a scene: ends a and b, radius, and the body's index."""

    a: np.ndarray
    b: np.ndarray
    radius: np.ndarray
    body: np.ndarray

    @classmethod
    def of(cls, scene) -> _Shapes:
        st = scene.state
        pos, n, lk = st.nodes.pos, st.nodes, st.links
        links = np.flatnonzero((lk.flags[: lk.count] & LINK_VISIBLE) != 0)
        spheres = np.flatnonzero((n.flags[: n.count] & NODE_SPHERE) != 0)
        return cls(np.vstack([pos[lk.a[links]], pos[spheres]]), np.vstack([pos[lk.b[links]], pos[spheres]]),
                   np.concatenate([lk.radius[links], n.radius[spheres]]),
                   np.concatenate([lk.body[links], n.body[spheres]]))  # fmt: skip


def _hidden_share(eye: np.ndarray, targets: np.ndarray, body: int, shapes: _Shapes) -> float:
    """The share of the sight lines from ``eye`` to ``targets`` (nodes of ``body``) that pass
    through another body's capsule or sphere."""
    others = shapes.body != body
    if not others.any():
        return 0.0
    gaps = _segment_gaps(np.repeat(eye[None], len(targets), axis=0), targets,
                         shapes.a[others], shapes.b[others])  # fmt: skip
    return float((gaps < shapes.radius[others][None]).any(axis=1).mean())


def closeup_camera(scene, names: tuple[str, ...], aspect: float,
                   yard: tuple[np.ndarray, np.ndarray] | None = None) -> CameraSpec:  # fmt: skip
    """An eye-and-target camera that frames the entities ``names`` (as they are now) side by
    side, low and close, from the side where they hide each other least and nothing else
    stands in front of them; ``yard``, the (x, z) corners of a fence round the scene, keeps
    the eye inside it."""
    st = scene.state
    pos, radius, node_body = st.nodes.pos, st.nodes.radius, st.nodes.body
    framed = _framed_rows(scene, names)
    every = np.concatenate(framed)
    offsets = np.vstack([np.eye(3), -np.eye(3)])
    points = (pos[every][:, None, :] + (radius[every][:, None, None] + 0.05) * offsets[None]).reshape(-1, 3)
    ends = [pos[rows].mean(axis=0) for rows in framed]
    along = ends[-1] - ends[0]  # the line between the two: looked at square-on
    along[1] = 0.0
    if np.linalg.norm(along) < 1e-3:
        along = np.array([0.0, 0.0, 1.0])
    base = math.degrees(math.atan2(along[0], along[2]))  # the yaw of an eye on that line
    shapes = _Shapes.of(scene)
    mine = np.isin(node_body[: st.nodes.count], [scene.entity(n).body.index for n in names])
    bystanders = pos[: st.nodes.count][~mine]
    best = None
    for side in (90.0, -90.0):
        for turn in TURNS:
            cam = OrbitCamera(np.zeros(3), yaw=(base + side + turn) % 360.0, pitch=PITCH)
            _fit(cam, points, aspect)
            eye = cam.eye
            hidden = np.mean(
                [_hidden_share(eye, pos[rows], int(node_body[rows[0]]), shapes) for rows in framed]
            )
            score = 10.0 * hidden + 0.003 * abs(turn) + _clutter(cam, bystanders, aspect, len(every))
            if yard is not None:
                lo, hi = yard
                outside = np.maximum(
                    np.maximum(lo + FENCE_ROOM - eye[[0, 2]], eye[[0, 2]] - hi + FENCE_ROOM), 0
                )
                score += 5.0 * float(outside.max() > 0)
            if best is None or score < best[0]:
                best = (score, cam)
    cam = best[1]
    return CameraSpec(mode="eye", eye=cam.eye, target=cam.target.copy())


def _fit(cam: OrbitCamera, points: np.ndarray, aspect: float) -> None:
    """Aim ``cam`` at the middle of ``points`` and back it off until they are all in view,
    ``MARGIN`` from the picture's sides and ``MARGIN_UP`` from its top and bottom (as
    :meth:`OrbitCamera.fit`, with a margin of each)."""
    cam.target = (points.min(axis=0) + points.max(axis=0)) / 2.0
    right, up, back = cam.basis()
    tan_y = math.tan(math.radians(cam.fov_y) / 2.0)
    tan_x, tan_y = tan_y * aspect / MARGIN, tan_y / MARGIN_UP
    rel = points - cam.target
    need = np.maximum(np.abs(rel @ right) / tan_x, np.abs(rel @ up) / tan_y) + rel @ back
    cam.distance = max(1.0, float(need.max()))


def _clutter(cam: OrbitCamera, bystanders: np.ndarray, aspect: float, framed: int) -> float:
    """Nodes of other bodies in the picture in front of what it frames, per framed node."""
    if not len(bystanders):
        return 0.0
    xy = cam.project(bystanders, 200, round(200 / aspect))
    depth = (bystanders - cam.eye) @ -cam.direction
    inside = (xy[:, 0] >= 0) & (xy[:, 0] <= 200) & (xy[:, 1] >= 0) & (xy[:, 1] <= 200 / aspect)
    return float((inside & (depth > 0) & (depth < cam.distance)).sum()) / max(framed, 1)


def camera_text(spec: CameraSpec) -> str:
    """``EX,EY,EZ@TX,TY,TZ`` (cm precision): an eye camera as ``--camera`` takes it."""
    return ",".join(f"{v:.2f}" for v in spec.eye) + "@" + ",".join(f"{v:.2f}" for v in spec.target)
