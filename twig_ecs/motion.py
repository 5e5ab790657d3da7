"""Motion capture of a run: every body's node positions, frame by frame, as numpy arrays.

A :class:`MotionRecorder` watches a scene as it steps and keeps one (frames, nodes, 3)
array per body, sampled at 30 or 60 frames a second, beside what an exporter needs to
dress it: the body's rest pose (its template at its height, facing +z at the origin),
its visible capsules and their colours. :mod:`twig_ecs.skeleton` turns a figure's
tracks into bone rotations; :mod:`twig_ecs.export` writes them as BVH or glTF.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass, field

import numpy as np

from twig_ecs.clock import FixedStepClock
from twig_ecs.components import Body
from twig_ecs.errors import TwigError
from twig_ecs.progress import Progress
from twig_ecs.store import LINK_VISIBLE, NODE_SPHERE, ROLES

#: Frame rates a recording may have: the step rate (60) or every second step (30).
FRAME_RATES = (30, 60)


class MotionError(TwigError):
    """A recording asked for something it cannot do (a frame rate, a body it does not hold)."""


@dataclass
class BodyTrack:
    """One body's motion: ``positions[f, k]`` is node ``node_names[k]`` at frame ``f`` (m)."""

    name: str
    template: str
    node_names: tuple[str, ...]
    rest: np.ndarray  # (n, 3) the template at the body's height, facing +z at the origin
    radius: np.ndarray  # (n,) node radius (a ball's sphere)
    sphere: np.ndarray  # (n,) bool: the node is drawn as a sphere
    links: list[tuple[int, int, float, tuple[float, float, float, float]]]  # visible: a, b, radius, rgba
    color: tuple[float, float, float, float]
    height: float  # m, as spawned (the skeleton's scale)
    frames: list[np.ndarray] = field(default_factory=list)
    #: a character's face direction per frame (its gaze controller's ``face_dir``: the head is one
    #: node, so where it looks is controller state); None for a body that is no character
    faces: list[np.ndarray] | None = None

    @property
    def positions(self) -> np.ndarray:
        """(frames, nodes, 3) node positions (m)."""
        return np.stack(self.frames) if self.frames else np.zeros((0, len(self.node_names), 3))

    @property
    def face_directions(self) -> np.ndarray | None:
        """(frames, 3) unit vectors the face points along, or None (no character)."""
        return np.stack(self.faces) if self.faces else None

    @property
    def is_figure(self) -> bool:
        """Does it have every humanoid node (a character or the ragdoll): is it rigged with a skeleton?"""
        return set(ROLES) <= set(self.node_names)

    def is_static(self) -> bool:
        """Did none of its nodes move (by more than 0.1 mm) over the recording?"""
        p = self.positions
        return len(p) == 0 or float(np.abs(p - p[0]).max()) < 1e-4


class MotionRecorder:
    """Records every body of ``scene`` at ``fps`` (30 or 60) frames a second as it steps.

    Call :meth:`capture` after each ``scene.step()`` of a loop you own, or :meth:`run` to
    step the scene for some seconds and capture as it goes. The first frame is the
    scene as it is when the recorder is made. Bodies spawned later are not recorded; a
    body removed meanwhile ends the recording with an error.
    """

    def __init__(self, scene, fps: int = 30) -> None:
        if fps not in FRAME_RATES:
            raise MotionError(f"a recording's frame rate must be one of {FRAME_RATES}, got {fps!r}")
        steps_per_second = round(1.0 / scene.dt)
        self.scene, self.fps = scene, fps
        self.every = max(1, steps_per_second // fps)
        self.tracks: dict[str, BodyTrack] = {}
        for name in scene.entity_names:
            body = scene.world.try_component(scene.entity_id(name), Body)
            if body is not None:
                self.tracks[name] = self._track(name, body)
        self._steps = 0
        self._grab()

    def _track(self, name: str, body: Body) -> BodyTrack:
        state, n = self.scene.state, len(body.node_names)
        rows = slice(body.node_start, body.node_start + n)
        try:
            template = self.scene.library.template(body.template)
        except (TwigError, KeyError):
            template = None
        if template is not None and template.node_names == body.node_names:
            rest = np.array([spec.at for spec in template.nodes], dtype=np.float64)
            rest *= body.height / template.reference_height
        else:  # a template this library lacks (a restored snapshot's): the body as it stands now
            rest = state.nodes.pos[rows] - state.nodes.pos[rows].mean(axis=0)
        links = []
        lk = state.links
        for row in range(body.link_start, body.link_start + body.link_count):
            if lk.flags[row] & LINK_VISIBLE and lk.radius[row] > 0:
                rgba = tuple(float(c) for c in lk.color[row])
                links.append(
                    (int(lk.a[row]) - rows.start, int(lk.b[row]) - rows.start, float(lk.radius[row]), rgba)
                )
        color = tuple(float(c) for c in state.nodes.color[rows.start])
        sphere = (state.nodes.flags[rows] & NODE_SPHERE) != 0
        radius = state.nodes.radius[rows].copy()
        track = BodyTrack(
            name, body.template, body.node_names, rest, radius, sphere, links, color, body.height
        )
        if self._character_row(body) is not None:
            track.faces = []
        return track

    def _character_row(self, body: Body) -> int | None:
        ch = self.scene.state.characters
        rows = np.flatnonzero(ch.body[: ch.count] == body.index)
        return int(rows[0]) if len(rows) else None

    def _grab(self) -> None:
        pos = self.scene.state.nodes.pos
        for name, track in self.tracks.items():
            if not self.scene.has_entity(name):
                raise MotionError(f"'{name}' was removed while its motion was being recorded")
            body = self.scene.entity(name).body
            track.frames.append(pos[body.rows].copy())
            if track.faces is not None:
                row = self._character_row(body)  # rows move when bodies are removed
                assert row is not None, f"'{name}' stopped being a character"
                track.faces.append(self.scene.state.characters.face_dir[row].copy())

    @property
    def frame_count(self) -> int:
        """Frames captured so far (the first is the starting pose)."""
        return len(next(iter(self.tracks.values())).frames) if self.tracks else 0

    def capture(self) -> None:
        """Note that the scene made one more step: every ``60 / fps``-th step becomes a frame."""
        self._steps += 1
        if self._steps % self.every == 0:
            self._grab()

    def run(self, seconds: float, progress: bool = False) -> None:
        """Step the scene ``seconds`` simulated seconds, capturing as it goes (progress on stderr)."""
        steps = FixedStepClock(self.scene.dt).steps_for(seconds)
        shown = Progress(sys.stderr, f"{self.scene.name}: recording") if progress else None
        try:
            for k in range(steps):
                self.scene.step()
                self.capture()
                if shown is not None:
                    shown(k + 1, steps)
        finally:
            if shown is not None:
                shown.done()

    def figures(self) -> list[str]:
        """Names of the recorded bodies that have a humanoid skeleton, in scene order."""
        return [name for name, track in self.tracks.items() if track.is_figure]
