"""Bone rotations from point masses: a humanoid joint hierarchy fitted to a figure's node track.

A twig body has no bones, only nodes joined by links, so every bone's rotation is built
from node positions. Each joint sits on a node; its bind pose is the body's rest pose
(the template at its height, facing +z, every joint rotation the identity), so a bone's
offset is the rest distance between its node and its parent's. Per frame:

- a *frame* joint (the pelvis, the chest) turns rigidly with a piece the body holds
  rigid: its x axis along a bar (the hip bar, the shoulder bar: this is where twist
  comes from), its y axis up the spine, made orthogonal; world rotation = F(t) F(rest)^T;
- an *aim* joint (spine, neck, clavicles, arms, legs) turns by the smallest rotation,
  in its parent's frame, that takes its rest bone direction to the current one - the
  twist it carries is its parent's, so the hip bar twists the legs, the shoulder bar the
  arms; a thigh then turns about its own axis to line the knee's hinge up with the plane
  the leg bends in, so the shin bends about one axis, as a rig's knee does;
- the *head* faces where the character's gaze controller turned its face (``face_dir``:
  the head is one node, so its facing is controller state), its y axis up the neck; a
  body with no face (the ragdoll) keeps the neck's rotation;
- a *tip* joint (hands, feet: one node each, no bone of their own) keeps its parent's
  rotation.

Quaternions are (x, y, z, w), kept sign-continuous from frame to frame (no flips).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

FRAME, AIM, TIP, FACE = "frame", "aim", "tip", "face"

#: (joint, node it sits on, parent joint, rule, for AIM: the node it points at;
#: for FRAME: (bar left end, bar right end, up from, up to); for FACE: the node below it).
#: Parents come first.
HUMANOID: tuple[tuple[str, str, str | None, str, object], ...] = (
    ("Hips", "pelvis", None, FRAME, ("l_hip", "r_hip", "pelvis", "spine")),
    ("LeftUpLeg", "l_hip", "Hips", AIM, "l_knee"),
    ("LeftLeg", "l_knee", "LeftUpLeg", AIM, "l_foot"),
    ("LeftFoot", "l_foot", "LeftLeg", TIP, None),
    ("RightUpLeg", "r_hip", "Hips", AIM, "r_knee"),
    ("RightLeg", "r_knee", "RightUpLeg", AIM, "r_foot"),
    ("RightFoot", "r_foot", "RightLeg", TIP, None),
    ("Spine", "spine", "Hips", AIM, "neck"),
    ("Chest", "neck", "Spine", FRAME, ("l_shoulder", "r_shoulder", "spine", "neck")),
    ("Neck", "neck", "Chest", AIM, "head"),
    ("Head", "head", "Neck", FACE, "neck"),
    ("LeftShoulder", "neck", "Chest", AIM, "l_shoulder"),
    ("LeftArm", "l_shoulder", "LeftShoulder", AIM, "l_elbow"),
    ("LeftForeArm", "l_elbow", "LeftArm", AIM, "l_hand"),
    ("LeftHand", "l_hand", "LeftForeArm", TIP, None),
    ("RightShoulder", "neck", "Chest", AIM, "r_shoulder"),
    ("RightArm", "r_shoulder", "RightShoulder", AIM, "r_elbow"),
    ("RightForeArm", "r_elbow", "RightArm", AIM, "r_hand"),
    ("RightHand", "r_hand", "RightForeArm", TIP, None),
)

#: Where a tip joint's "End Site" points in the bind pose, in metres at 1.75 m tall.
#: Upper limbs whose twist is set by the hinge below them: joint -> the node past the hinge.
#: Only the legs: a twig knee is a hinge (it bends forwards, 8 degrees either side at most),
#: an elbow is a ball joint with limits (40 degrees in, 110 out), whose bend plane swings
#: fast as the arm straightens - lining it up made the upper arms spin, 93 times in a 10 s
#: schoolyard by more than 45 degrees in a frame (11 without)
HINGES = {"LeftUpLeg": "l_foot", "RightUpLeg": "r_foot"}
#: A hinge bent less than this (sine of the angle) gives its upper limb no twist; bent more
#: than the second, all of it; in between a share, so a limb straightening does not snap.
HINGE_BEND = (np.sin(np.radians(5.0)), np.sin(np.radians(20.0)))

END_SITES = {
    "Head": (0.0, 0.14, 0.0),
    "LeftFoot": (0.0, -0.03, 0.12),
    "RightFoot": (0.0, -0.03, 0.12),
    "LeftHand": (0.0, -0.08, 0.0),
    "RightHand": (0.0, -0.08, 0.0),
}

#: Which joint a visible link (by its node names, either order) is skinned to.
LINK_JOINTS = {
    ("pelvis", "spine"): "Hips",
    ("l_hip", "r_hip"): "Hips",
    ("spine", "neck"): "Spine",
    ("neck", "head"): "Neck",
    ("l_shoulder", "r_shoulder"): "Chest",
    ("l_hip", "l_knee"): "LeftUpLeg",
    ("l_knee", "l_foot"): "LeftLeg",
    ("r_hip", "r_knee"): "RightUpLeg",
    ("r_knee", "r_foot"): "RightLeg",
    ("l_shoulder", "l_elbow"): "LeftArm",
    ("l_elbow", "l_hand"): "LeftForeArm",
    ("r_shoulder", "r_elbow"): "RightArm",
    ("r_elbow", "r_hand"): "RightForeArm",
}


@dataclass
class Skeleton:
    """A figure's fitted motion: the hierarchy, its bind pose and per-frame joint rotations."""

    names: tuple[str, ...]
    parents: np.ndarray  # (J,) parent joint index, -1 for the root
    offsets: np.ndarray  # (J, 3) rest offset from the parent joint (the root's: its rest position)
    bind: np.ndarray  # (J, 3) rest world position of each joint
    root_translation: np.ndarray  # (F, 3) the root joint's position (m)
    local: np.ndarray  # (F, J, 4) local rotations as unit quaternions (x, y, z, w)
    world: np.ndarray  # (F, J, 3, 3) world rotations
    scale: float  # body height / 1.75 m (for end sites)

    def joint_positions(self) -> np.ndarray:
        """(F, J, 3) joint positions by forward kinematics from the root and the rotations."""
        out = np.empty((len(self.root_translation), len(self.names), 3))
        for j, parent in enumerate(self.parents):
            if parent < 0:
                out[:, j] = self.root_translation
            else:
                out[:, j] = out[:, parent] + self.world[:, parent] @ self.offsets[j]
        return out


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.maximum(n, 1e-12)


def _frame(bar: np.ndarray, up: np.ndarray) -> np.ndarray:
    """(…, 3, 3) orthonormal frame, columns x (along ``bar``), y (``up`` made orthogonal), z."""
    x = _unit(bar)
    y = _unit(up - (up * x).sum(-1, keepdims=True) * x)
    return np.stack([x, y, np.cross(x, y)], axis=-1)


def _facing(forward: np.ndarray, up: np.ndarray) -> np.ndarray:
    """(…, 3, 3) orthonormal frame, columns x, y (``up`` made orthogonal), z (along ``forward``)."""
    z = _unit(forward)
    y = _unit(up - (up * z).sum(-1, keepdims=True) * z)
    return np.stack([np.cross(y, z), y, z], axis=-1)


def _arc(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(F, 3, 3) the smallest rotation taking unit vector ``a`` (3,) to unit vectors ``b`` (F, 3)."""
    v = np.cross(a, b)
    c = b @ a
    k = np.zeros(b.shape[:-1] + (3, 3))
    k[..., 0, 1], k[..., 0, 2], k[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    k[..., 1, 0], k[..., 2, 0], k[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    # Rodrigues with sin/cos folded in: R = I + K + K^2 / (1 + c); near c = -1 (a half turn)
    # the axis is ill-defined and any will do
    return np.eye(3) + k + (k @ k) / np.maximum(1.0 + c, 1e-9)[..., None, None]


def _about(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """(F, 3, 3) rotations by ``angle`` (F,) radians about the unit ``axis`` (3,) (Rodrigues)."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    return np.eye(3) + s * k + (1.0 - c) * (k @ k)


def _hinge_twist(rest, positions, at, here, mid, tip, placed, world) -> np.ndarray:
    """(F, 3, 3) the twist about an upper limb's own axis that lines its hinge (knee, elbow) up.

    The limb was aimed by the smallest rotation, which leaves the plane the limb bends in
    wherever its parent's twist put it. Turned about its own axis so that the rest pose's
    bend axis lies along the current one, the lower limb's rotation is a bend about one
    axis, as a rig's knee and elbow expect. The child's position does not move (it lies on
    the axis). A nearly straight limb has no bend plane: it gets a share of the twist that
    falls to none below :data:`HINGE_BEND`.
    """
    axis = _unit(rest[at[mid]] - rest[at[here]])
    bend_rest = np.cross(rest[at[mid]] - rest[at[here]], rest[at[tip]] - rest[at[mid]])
    if np.linalg.norm(bend_rest) < 1e-9:  # a template whose limb is straight at rest
        return np.broadcast_to(np.eye(3), world.shape)
    upper, lower = positions[:, at[mid]] - placed, positions[:, at[tip]] - positions[:, at[mid]]
    bend = np.cross(upper, lower)
    lengths = np.linalg.norm(upper, axis=-1) * np.linalg.norm(lower, axis=-1)
    sine = np.linalg.norm(bend, axis=-1) / np.maximum(lengths, 1e-12)
    seen = (np.swapaxes(world, -1, -2) @ bend[..., None])[..., 0]  # in the limb's frame
    want = seen - (seen @ axis)[:, None] * axis
    have = bend_rest - (bend_rest @ axis) * axis
    # a twig elbow or knee may bend either way about its axis (a hinge of a point-mass body
    # is a limited ball joint), so the axis is lined up either way round: the twist is taken
    # modulo a half turn (doubled, unwrapped, halved), and a limb bending back bends by a
    # negative angle rather than turning over
    double = 2.0 * np.arctan2(np.cross(have, want) @ axis, want @ have)
    low, high = HINGE_BEND
    share = np.clip((sine - low) / (high - low), 0.0, 1.0)
    return _about(axis, 0.5 * _unwrapped_while(np.angle(np.exp(1j * double)), share > 0) * share)


def _unwrapped_while(angle: np.ndarray, bent: np.ndarray) -> np.ndarray:
    """``angle`` (F,) made continuous over each run of ``bent`` frames, each run starting within a half turn.

    An angle passing the half turn would otherwise snap from +180 to -180 degrees in a
    frame; between runs the limb is straight and its twist share is zero.
    """
    out = np.unwrap(angle)
    starts = np.flatnonzero(bent & ~np.concatenate([[False], bent[:-1]]))
    ends = np.append(starts[1:], len(angle))[: len(starts)]
    for start, end in zip(starts, ends, strict=True):
        turns = np.round(out[start] / (2.0 * np.pi))
        out[start:end] -= turns * 2.0 * np.pi
    return out


def quaternions(m: np.ndarray) -> np.ndarray:
    """(…, 4) unit quaternions (x, y, z, w) of rotation matrices (…, 3, 3) (Shepperd's method)."""
    m = np.asarray(m, dtype=np.float64)
    t = np.stack([m[..., 0, 0], m[..., 1, 1], m[..., 2, 2], np.trace(m, axis1=-2, axis2=-1)], -1)
    pick = t.argmax(-1)
    q = np.empty(m.shape[:-2] + (4,))
    for k in range(4):
        sel = pick == k
        if not sel.any():
            continue
        r = m[sel]
        if k == 3:
            s = 2.0 * np.sqrt(np.maximum(1.0 + t[sel][:, 3], 1e-12))
            q[sel] = np.stack(
                [
                    (r[:, 2, 1] - r[:, 1, 2]) / s,
                    (r[:, 0, 2] - r[:, 2, 0]) / s,
                    (r[:, 1, 0] - r[:, 0, 1]) / s,
                    0.25 * s,
                ],
                -1,
            )
        else:
            i, j, m2 = k, (k + 1) % 3, (k + 2) % 3
            s = 2.0 * np.sqrt(np.maximum(1.0 + r[:, i, i] - r[:, j, j] - r[:, m2, m2], 1e-12))
            out = np.empty((len(r), 4))
            out[:, i] = 0.25 * s
            out[:, j] = (r[:, j, i] + r[:, i, j]) / s
            out[:, m2] = (r[:, m2, i] + r[:, i, m2]) / s
            out[:, 3] = (r[:, m2, j] - r[:, j, m2]) / s
            q[sel] = out
    return _unit(q)


def continuous(q: np.ndarray) -> np.ndarray:
    """Quaternions (F, …, 4) with each frame's sign chosen to agree with the frame before it."""
    q = q.copy()
    for f in range(1, len(q)):
        flip = (q[f] * q[f - 1]).sum(-1) < 0
        q[f][flip] *= -1
    return q


def fit(node_names: tuple[str, ...], rest: np.ndarray, positions: np.ndarray, height: float,
        face: np.ndarray | None = None) -> Skeleton:  # fmt: skip
    """Fit the humanoid hierarchy to a figure's node track ``positions`` (F, n, 3) (m).

    ``rest`` (n, 3) is the body's rest pose, which gives the bone offsets and the bind pose.
    ``face`` (F, 3): where a character's face points each frame (None: the head keeps the
    neck's rotation).
    """
    at = {name: k for k, name in enumerate(node_names)}
    names = tuple(j[0] for j in HUMANOID)
    index = {name: k for k, name in enumerate(names)}
    frames, count = len(positions), len(HUMANOID)
    parents = np.array([index[p] if p else -1 for _, _, p, _, _ in HUMANOID])
    bind = np.array([rest[at[node]] for _, node, _, _, _ in HUMANOID])
    offsets = np.array([bind[j] - (bind[parents[j]] if parents[j] >= 0 else 0.0) for j in range(count)])
    world = np.empty((frames, count, 3, 3))
    local = np.empty((frames, count, 3, 3))

    def node(name: str) -> np.ndarray:
        return positions[:, at[name]]

    placed = np.empty((frames, count, 3))  # where forward kinematics puts each joint so far
    for j, (_, here, _, rule, arg) in enumerate(HUMANOID):
        parent = world[:, parents[j]] if parents[j] >= 0 else np.broadcast_to(np.eye(3), (frames, 3, 3))
        if parents[j] >= 0:
            placed[:, j] = placed[:, parents[j]] + parent @ offsets[j]
        else:
            placed[:, j] = node(here)
        if rule == FRAME:
            left, right, low, high = arg
            now = _frame(node(left) - node(right), node(high) - node(low))
            bound = _frame(rest[at[left]] - rest[at[right]], rest[at[high]] - rest[at[low]])
            world[:, j] = now @ bound.T
            local[:, j] = np.swapaxes(parent, -1, -2) @ world[:, j]
        elif rule == AIM:
            # aimed from where the joint was placed, not from its node: an error up the chain
            # (a stretched link) is not handed down to the bones below
            direction = _unit(node(arg) - placed[:, j])
            seen = (np.swapaxes(parent, -1, -2) @ direction[..., None])[..., 0]  # in the parent's frame
            local[:, j] = _arc(_unit(rest[at[arg]] - rest[at[here]]), _unit(seen))
            if names[j] in HINGES:
                local[:, j] = local[:, j] @ _hinge_twist(rest, positions, at, here, arg, HINGES[names[j]],
                                                         placed[:, j], parent @ local[:, j])  # fmt: skip
            world[:, j] = parent @ local[:, j]
        elif rule == FACE and face is not None:
            now = _facing(face, node(here) - node(arg))
            bound = _facing(np.array([0.0, 0.0, 1.0]), rest[at[here]] - rest[at[arg]])  # rest faces +z
            world[:, j] = now @ bound.T
            local[:, j] = np.swapaxes(parent, -1, -2) @ world[:, j]
        else:
            local[:, j] = np.eye(3)
            world[:, j] = parent
    return Skeleton(
        names,
        parents,
        offsets,
        bind,
        node("pelvis").copy(),
        continuous(quaternions(local)),
        world,
        height / 1.75,
    )
