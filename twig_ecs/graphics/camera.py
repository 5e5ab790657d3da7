"""The orbit camera: a target point seen from a yaw, pitch and distance.

Angles are degrees. Yaw 0 puts the eye on the +z side of the target looking towards -z;
positive yaw turns the eye towards +x. Pitch is the elevation of the eye above the
target's horizontal plane. ``view_matrix``/``projection_matrix`` return column-major
float32 matrices ready for GLSL (numpy arrays in row-major maths, transposed on upload).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twig_ecs.errors import TwigError

#: The lowest the eye of a camera moved by the mouse or keys may go (m above the ground): a
#: camera under the ground shows the scene's underside through a floor drawn from one side.
MIN_EYE_HEIGHT = 0.2


class CameraError(TwigError):
    """A camera specification (``--camera``) that cannot be understood."""


@dataclass
class OrbitCamera:
    """A perspective camera orbiting ``target``; y is up."""

    target: np.ndarray
    yaw: float = 35.0
    pitch: float = 25.0
    distance: float = 10.0
    fov_y: float = 40.0  # vertical field of view (degrees)
    near: float = 0.05
    far: float = 400.0

    def __post_init__(self) -> None:
        self.target = np.asarray(self.target, dtype=np.float64).copy()

    # -- geometry ------------------------------------------------------------------

    @property
    def direction(self) -> np.ndarray:
        """Unit vector from the target towards the eye."""
        yaw, pitch = math.radians(self.yaw), math.radians(self.pitch)
        return np.array([math.sin(yaw) * math.cos(pitch), math.sin(pitch), math.cos(yaw) * math.cos(pitch)])

    @property
    def eye(self) -> np.ndarray:
        """Eye position (m)."""
        return self.target + self.distance * self.direction

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(right, up, back) unit vectors of the view; ``back`` points from target to eye."""
        back = self.direction
        right = np.cross(np.array([0.0, 1.0, 0.0]), back)
        norm = np.linalg.norm(right)
        right = right / norm if norm > 1e-9 else np.array([1.0, 0.0, 0.0])
        up = np.cross(back, right)
        return right, up, back

    def view_matrix(self) -> np.ndarray:
        """World-to-camera 4x4 matrix."""
        right, up, back = self.basis()
        eye = self.eye
        m = np.identity(4)
        m[0, :3], m[1, :3], m[2, :3] = right, up, back
        m[:3, 3] = -m[:3, :3] @ eye
        return m

    def projection_matrix(self, aspect: float) -> np.ndarray:
        """OpenGL perspective 4x4 matrix for a viewport of ``aspect`` = width / height."""
        f = 1.0 / math.tan(math.radians(self.fov_y) / 2.0)
        n, fa = self.near, self.far
        m = np.zeros((4, 4))
        m[0, 0] = f / aspect
        m[1, 1] = f
        m[2, 2] = (fa + n) / (n - fa)
        m[2, 3] = 2.0 * fa * n / (n - fa)
        m[3, 2] = -1.0
        return m

    def view_projection(self, aspect: float) -> np.ndarray:
        """Projection @ view."""
        return self.projection_matrix(aspect) @ self.view_matrix()

    def project(self, points: np.ndarray, width: int, height: int) -> np.ndarray:
        """Pixel coordinates (x right, y down from the top-left) of world ``points`` (n, 3)."""
        pts = np.atleast_2d(np.asarray(points, dtype=np.float64))
        clip = np.c_[pts, np.ones(len(pts))] @ self.view_projection(width / height).T
        ndc = clip[:, :3] / clip[:, 3:4]
        return np.c_[(ndc[:, 0] + 1) * 0.5 * width, (1 - ndc[:, 1]) * 0.5 * height]

    # -- moving --------------------------------------------------------------------

    def orbit(self, d_yaw: float, d_pitch: float) -> None:
        """Turn around the target by degrees; pitch stays within [-5, 89], the eye above the ground."""
        self.yaw = (self.yaw + d_yaw) % 360.0
        self.pitch = min(89.0, max(-5.0, self.pitch + d_pitch))
        self.stay_above_ground()

    def stay_above_ground(self) -> None:
        """Raise the eye to :data:`MIN_EYE_HEIGHT` if it is lower: tilt the view down towards the
        target, and lift the target when even a view from above would leave the eye too low."""
        top = math.sin(math.radians(89.0)) * self.distance
        self.target[1] = max(self.target[1], MIN_EYE_HEIGHT - top)
        if self.eye[1] < MIN_EYE_HEIGHT:
            rise = (MIN_EYE_HEIGHT - self.target[1]) / self.distance
            self.pitch = min(89.0, math.degrees(math.asin(min(1.0, rise))) + 1e-6)

    def pan(self, dx: float, dz: float) -> None:
        """Move the target in the ground plane: ``dx`` to the right, ``dz`` away from the eye,
        in metres per unit of distance (so panning feels the same at every zoom)."""
        right, _, back = self.basis()
        ahead = -np.array([back[0], 0.0, back[2]])
        norm = np.linalg.norm(ahead)
        ahead = ahead / norm if norm > 1e-9 else np.array([0.0, 0.0, -1.0])
        self.target = self.target + self.distance * (dx * right + dz * ahead)

    def pan_screen(self, dx: float, dy: float) -> None:
        """Drag the target with the view plane: ``dx``/``dy`` in units of the distance."""
        right, up, _ = self.basis()
        self.target = self.target + self.distance * (-dx * right - dy * up)
        self.stay_above_ground()

    def zoom(self, factor: float) -> None:
        """Multiply the distance by ``factor`` (< 1 moves closer), within [0.5, 200] m."""
        self.distance = min(200.0, max(0.5, self.distance * factor))
        self.stay_above_ground()

    def follow(self, point: np.ndarray, dt: float, half_life: float = 0.25) -> None:
        """Move the target smoothly towards ``point`` (exponential, ``half_life`` seconds)."""
        k = 1.0 - 0.5 ** (dt / half_life) if half_life > 0 else 1.0
        self.target = self.target + k * (np.asarray(point, dtype=np.float64) - self.target)
        self.stay_above_ground()

    def fit(self, points: np.ndarray, aspect: float, margin: float = 1.1) -> None:
        """Aim at the middle of ``points`` (n, 3) and back off until all of them are in view."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        self.target = (pts.min(axis=0) + pts.max(axis=0)) / 2.0
        self.distance = self.distance_to_fit(pts, aspect, margin)

    def distance_to_fit(self, points: np.ndarray, aspect: float, margin: float = 1.1) -> float:
        """The distance from ``target`` at which every point is inside the view."""
        right, up, back = self.basis()
        tan_y = math.tan(math.radians(self.fov_y) / 2.0) / margin
        tan_x = tan_y * aspect
        rel = np.asarray(points, dtype=np.float64) - self.target
        # A point at (x, y) in the view plane and z towards the eye is in view when
        # |x| <= (d - z) tan_x and |y| <= (d - z) tan_y, so d >= z + |x| / tan_x (and y).
        need = np.maximum(np.abs(rel @ right) / tan_x, np.abs(rel @ up) / tan_y) + rel @ back
        return max(1.0, float(need.max()))

    def copy(self) -> OrbitCamera:
        return OrbitCamera(self.target, self.yaw, self.pitch, self.distance, self.fov_y, self.near, self.far)


def scene_points(state) -> np.ndarray:
    """Points that enclose every node of a :class:`PhysicsState`, and the ground each body
    could cover if it fell over (a circle of its height around it), or a small box around
    the origin when the scene is empty."""
    n = state.nodes
    if n.count == 0:
        return np.array([[x, y, z] for x in (-2.0, 2.0) for y in (0.0, 2.0) for z in (-2.0, 2.0)])
    pos = n.pos[: n.count]
    r = n.radius[: n.count, None] + 0.1
    offsets = np.vstack([np.eye(3), -np.eye(3)])
    points = [(pos[:, None, :] + r[:, :, None] * offsets[None]).reshape(-1, 3)]
    angles = np.linspace(0.0, 2 * math.pi, 8, endpoint=False)
    circle = np.c_[np.cos(angles), np.zeros(8), np.sin(angles)]
    body = n.body[: n.count]
    for b in np.unique(body):
        mine = pos[body == b]
        reach = 0.8 * float(mine[:, 1].max() - mine[:, 1].min())
        if reach > 0.3:
            base = np.array([mine[:, 0].mean(), 0.0, mine[:, 2].mean()])
            points.append(base + reach * circle)
    return np.vstack(points)


#: The view an ``auto`` camera prefers (degrees); it may turn up to AUTO_YAW_RANGE either
#: way when that lets it come closer (a scene spread along one line is best seen side-on).
DEFAULT_YAW = 205.0
DEFAULT_PITCH = 32.0
AUTO_YAW_RANGE = 60.0
#: The ``action`` camera: a character fills this share of the picture's height.
ACTION_HEIGHT_SHARE = 1.0 / 3.0
#: How much more a character moving at 1 m/s weighs than one standing, in the action's centre.
ACTION_SPEED_WEIGHT = 2.0


def character_heights(scene) -> dict[str, float]:
    """The characters of a scene (bodies with a head) and their standing heights (m)."""
    out = {}
    for name in scene.entity_names:
        handle = scene.entity(name)
        if "head" in handle.node_names:
            out[name] = float(handle.body.height)
    return out


def action_point(scene) -> np.ndarray | None:
    """Where the action is: the characters' centre on the ground, the moving ones weighing more.

    None when the scene has no characters.
    """
    names = list(character_heights(scene))
    if not names:
        return None
    points, weights = [], []
    for name in names:
        handle = scene.entity(name)
        points.append(handle.position)
        weights.append(1.0 + ACTION_SPEED_WEIGHT * float(np.linalg.norm(handle.velocity[[0, 2]])))
    centre = np.average(np.array(points), axis=0, weights=np.array(weights))
    return centre


def _floats(text: str, count: int, spec: str) -> np.ndarray:
    parts = text.split(",")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) != count:
        raise CameraError(f"camera '{spec}': expected {count} comma-separated numbers in '{text}'")
    return np.array(values)


@dataclass
class CameraSpec:
    """What ``--camera`` asked for: ``auto`` (the whole scene), ``action`` (the characters, a
    third of the picture high, at their centre), ``follow:NAME``, ``orbit:YAW,PITCH[,DIST]``
    or ``EX,EY,EZ[@TX,TY,TZ]`` (eye position, looking at the target, default the scene centre)."""

    mode: str = "auto"  # auto | action | follow | orbit | eye
    name: str = ""
    yaw: float = DEFAULT_YAW
    pitch: float = DEFAULT_PITCH
    distance: float | None = None
    eye: np.ndarray | None = None
    target: np.ndarray | None = None

    @classmethod
    def parse(cls, spec: str) -> CameraSpec:
        text = spec.strip()
        if text in ("", "auto"):
            return cls()
        if text == "action":
            return cls(mode="action")
        if text.startswith("follow:"):
            name = text.split(":", 1)[1].strip()
            if not name:
                raise CameraError("camera 'follow:NAME' needs an entity name, e.g. follow:parent")
            return cls(mode="follow", name=name)
        if text.startswith("orbit:"):
            body = text.split(":", 1)[1]
            n = len(body.split(","))
            if n not in (2, 3):
                raise CameraError(f"camera '{spec}': use orbit:YAW,PITCH or orbit:YAW,PITCH,DISTANCE")
            vals = _floats(body, n, spec)
            return cls(mode="orbit", yaw=vals[0], pitch=vals[1], distance=vals[2] if n == 3 else None)
        eye_text, _, target_text = text.partition("@")
        if len(eye_text.split(",")) != 3:
            raise CameraError(
                f"unknown camera '{spec}': use auto, follow:NAME, orbit:YAW,PITCH[,DIST] "
                "or EX,EY,EZ[@TX,TY,TZ]"
            )
        eye = _floats(eye_text, 3, spec)
        target = _floats(target_text, 3, spec) if target_text else None
        return cls(mode="eye", eye=eye, target=target)

    def make(self, scene, aspect: float) -> OrbitCamera:
        """A camera for ``scene`` (its current state) and a viewport ``aspect``."""
        cam = OrbitCamera(np.zeros(3), yaw=self.yaw, pitch=self.pitch)
        points = scene_points(scene.state)
        if self.mode == "follow":
            if not scene.has_entity(self.name):
                names = ", ".join(scene.entity_names) or "none"
                raise CameraError(f"camera follow:{self.name}: no entity of that name (entities: {names})")
            cam.target = scene.entity(self.name).position
            cam.distance = 6.0
            return cam
        if self.mode == "action":
            centre = action_point(scene)
            if centre is not None:
                cam.target = centre
                cam.distance = action_distance(scene, cam.fov_y)
                return cam
            # no characters: the whole scene, as auto frames it
        if self.mode == "eye":
            target = self.target if self.target is not None else (points.min(0) + points.max(0)) / 2.0
            offset = self.eye - target
            dist = float(np.linalg.norm(offset))
            if dist < 1e-6:
                raise CameraError("camera: the eye and the target are the same point")
            cam.target = np.asarray(target, dtype=np.float64)
            cam.distance = dist
            cam.pitch = math.degrees(math.asin(max(-1.0, min(1.0, offset[1] / dist))))
            cam.yaw = math.degrees(math.atan2(offset[0], offset[2]))
            return cam
        if self.mode in ("auto", "action"):
            best = None
            for yaw in np.arange(-AUTO_YAW_RANGE, AUTO_YAW_RANGE + 1, 10.0) + self.yaw:
                cam.yaw = float(yaw) % 360.0
                cam.fit(points, aspect)
                # Prefer the default view unless turning saves more than a few per cent.
                score = cam.distance * (1.0 + 0.001 * abs(yaw - self.yaw))
                if best is None or score < best[0]:
                    best = (score, cam.yaw)
            cam.yaw = best[1]
        cam.fit(points, aspect)
        if self.distance is not None:
            cam.distance = self.distance
        return cam


def action_distance(scene, fov_y: float) -> float:
    """The distance at which the scene's tallest character fills ACTION_HEIGHT_SHARE of the picture."""
    heights = character_heights(scene)
    height = max(heights.values()) if heights else 1.75
    return height / (ACTION_HEIGHT_SHARE * 2.0 * math.tan(math.radians(fov_y) / 2.0))
