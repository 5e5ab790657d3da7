"""Torsos the right way out: a humanoid torso turned into a mirror image of itself is put back.

A humanoid's torso is five nodes held rigid by links (pelvis, both hips, mid-spine, neck),
and they lie nearly in one plane: the pelvis sits 3 cm and the mid-spine 6 cm behind the hip
bar. A mirror image keeps every link length, or all but one by a few millimetres, so the
links cannot tell it from the right shape, and a hard push (a run's landing, a hug, a fall)
can flip it and leave it so: the pelvis popped through to the front of the hips and the
mid-spine (schoolyard seed 0: the big child for 5 s of a run, the small child for 15 s and
30 s in the first minute), or the whole lower back bowed forwards. The body looks the same
from afar, but its hip frame - the knees' hinge frame, a motion export's pelvis bone - is no
longer a rotation of the rest one (the export's hips 4.6 cm off the simulated nodes).

After the constraints, each character whose mid-spine lies in front of the plane of the
hip bar and the neck has the mid-spine and pelvis reflected back through that plane; then
one whose pelvis lies in front of the plane of the hip bar and the mid-spine has its pelvis
reflected back through that one. A reflection keeps the lengths of the links to the nodes
in the plane, and the moved nodes' velocities are kept as they were. Left alone: a body
lying down or limp, and a stooping one (see :func:`right_way_out`).
"""

from __future__ import annotations

import numpy as np

from twig_ecs.kernelmath import L_HIP, LIMP, NECK, PELVIS, R_HIP, SPINE

#: How far in front of its plane (m at 1.75 m tall) a node must be to be inside out: at rest
#: the mid-spine is 4.5 cm behind the hip-neck plane and the pelvis 2.9 cm behind the
#: hip-spine one, and the links keep each within a few mm of that or of its mirror image.
INSIDE_OUT = 0.01
#: The least pelvis height (m at 1.75 m tall) of a body that is put back: about half its standing one.
UP = 0.45


def right_way_out(state) -> int:
    """Put back every character's torso that is inside out; returns how many were."""
    characters = state.characters
    count = characters.count
    if count == 0:
        return 0
    rows = characters.nodes[:count]
    scale = characters.scale[:count]
    # only bodies up on their feet: lying on its back, the ground itself presses the pelvis and
    # mid-spine up level with the hips and beyond (put back, they went into the ground again
    # each step, and a limp body shook in the hands of one dragging it); and not stooping: the
    # stoop's own pull on the pelvis takes it through and back, and put back there, a
    # dragger reaching down took hold elsewhere and lifted its load (left for the posture)
    up = (characters.mode[:count] != LIMP) & (state.nodes.pos[rows[:, PELVIS], 1] > UP * scale)
    up &= characters.crouch[:count] <= 0.0
    least = np.where(up, INSIDE_OUT * scale, np.inf)
    flipped = _reflect(state, rows, NECK, (SPINE, PELVIS), least)  # the lower back bowed forwards
    flipped |= _reflect(state, rows, SPINE, (PELVIS,), least)  # the pelvis through to the front
    return int(flipped.sum())


def _reflect(state, rows: np.ndarray, top: int, moved: tuple[int, ...], least: np.ndarray) -> np.ndarray:
    """Reflect the ``moved`` roles of each character whose first one lies more than ``least``
    in front of the plane through its hip bar and its ``top`` node back through that plane;
    returns which characters were."""
    pos, prev = state.nodes.pos, state.nodes.prev
    left, right, high = pos[rows[:, L_HIP]], pos[rows[:, R_HIP]], pos[rows[:, top]]
    middle = 0.5 * (left + right)
    normal = np.cross(left - right, high - middle)  # forwards: left x up
    length = np.linalg.norm(normal, axis=1)
    normal /= np.maximum(length, 1e-12)[:, None]
    ahead = [np.einsum("ij,ij->i", pos[rows[:, role]] - middle, normal) for role in moved]
    flipped = (length > 1e-9) & (ahead[0] > least)
    for role, off in zip(moved, ahead, strict=True):
        nodes = rows[flipped, role]
        move = -2.0 * off[flipped, None] * normal[flipped]
        pos[nodes] += move
        prev[nodes] += move  # (their velocities as they were)
    return flipped
