"""Measurements for tests, written independently of the kernels they check."""

from __future__ import annotations

import math

import numpy as np

from twig_ecs.store import LINK_COLLIDE, NODE_SPHERE


def _closest(p1, q1, p2, q2, samples: int = 41) -> float:
    """Distance between two segments by dense sampling and refinement (slow, simple)."""
    ts = np.linspace(0.0, 1.0, samples)
    a = p1[None, :] + ts[:, None] * (q1 - p1)[None, :]
    b = p2[None, :] + ts[:, None] * (q2 - p2)[None, :]
    d = np.linalg.norm(a[:, None, :] - b[None, :, :], axis=2)
    return float(d.min())


def max_overlap_between_bodies(scene) -> float:
    """Deepest overlap (m) between colliders of different bodies (0 if none)."""
    st = scene.state
    n, lk = st.nodes, st.links
    links = np.nonzero(lk.flags[: lk.count] & LINK_COLLIDE)[0]
    spheres = np.nonzero(n.flags[: n.count] & NODE_SPHERE)[0]
    # every collider as a capsule (body, end a, end b, radius); a sphere's ends coincide
    body = np.concatenate([lk.body[links], n.body[spheres]])
    a = np.concatenate([n.pos[lk.a[links]], n.pos[spheres]])
    b = np.concatenate([n.pos[lk.b[links]], n.pos[spheres]])
    radius = np.concatenate([lk.radius[links], n.radius[spheres]])
    # cheap reject on bounding boxes, for every pair at once; the pairs left are measured
    lo = np.minimum(a, b) - radius[:, None]
    hi = np.maximum(a, b) + radius[:, None]
    x, y = np.triu_indices(len(body), k=1)
    near = (body[x] != body[y]) & (lo[x] <= hi[y]).all(axis=1) & (lo[y] <= hi[x]).all(axis=1)
    worst = 0.0
    for i, j in zip(x[near], y[near], strict=True):
        worst = max(worst, radius[i] + radius[j] - _closest(a[i], b[i], a[j], b[j]))
    return worst


def knee_hyperextension(handle) -> float:
    """How far the more bent-backwards knee points behind its hip-foot line.

    Returns the knee's backward offset from that line as a fraction of the hip-foot
    distance (0.02 is about 1 degree of hyperextension at the knee); 0 or less when
    both knees bend forwards or are straight. Backward is against the body's forward,
    (left hip - right hip) x (spine - pelvis).
    """
    p = {name: handle.node(name) for name in handle.node_names}
    forward = np.cross(p["l_hip"] - p["r_hip"], p["spine"] - p["pelvis"])
    worst = -1.0
    for side in ("l", "r"):
        hip, knee, foot = p[f"{side}_hip"], p[f"{side}_knee"], p[f"{side}_foot"]
        length = np.linalg.norm(foot - hip)
        axis = (foot - hip) / length
        v = knee - hip
        v = v - (v @ axis) * axis
        f = forward - (forward @ axis) * axis
        f /= np.linalg.norm(f)
        worst = max(worst, float(-(v @ f) / length))
    return worst


def total_momentum(scene) -> np.ndarray:
    """Sum of m v over all free nodes, v from the last step's displacement."""
    return scene.state.momentum(dt=scene.dt)


def angle_about_y(v: np.ndarray) -> float:
    """Heading angle (rad) of a vector projected on the ground plane."""
    return math.atan2(v[0], v[2])
