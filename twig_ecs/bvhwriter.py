"""BVH (Biovision hierarchy) output of a fitted :class:`~twig_ecs.skeleton.Skeleton`.

The hierarchy is the skeleton's, offsets in metres from the body's rest pose, the root
with ``Xposition Yposition Zposition Zrotation Xrotation Yrotation`` and every other joint
with ``Zrotation Xrotation Yrotation`` (the common CMU layout: a joint's local rotation is
Rz * Rx * Ry), angles in degrees, unwrapped from frame to frame so that players
interpolating them never spin the long way round. The root's OFFSET is zero: its
position channels are its world position.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from twig_ecs.skeleton import END_SITES, Skeleton

ROOT_CHANNELS = "Xposition Yposition Zposition Zrotation Xrotation Yrotation"
JOINT_CHANNELS = "Zrotation Xrotation Yrotation"


def euler_zxy(m: np.ndarray) -> np.ndarray:
    """(…, 3) angles (z, x, y) in radians with ``m = Rz(z) @ Rx(x) @ Ry(y)``, for matrices (…, 3, 3)."""
    x = np.arcsin(np.clip(m[..., 2, 1], -1.0, 1.0))
    z = np.arctan2(-m[..., 0, 1], m[..., 1, 1])
    y = np.arctan2(-m[..., 2, 0], m[..., 2, 2])
    return np.stack([z, x, y], axis=-1)


def local_matrices(skeleton: Skeleton) -> np.ndarray:
    """(F, J, 3, 3) each joint's rotation relative to its parent."""
    w, parents = skeleton.world, skeleton.parents
    out = w.copy()
    has = parents >= 0
    out[:, has] = np.swapaxes(w[:, parents[has]], -1, -2) @ w[:, has]
    return out


def write_bvh(skeleton: Skeleton, path: str | Path, fps: int) -> Path:
    """Write ``skeleton``'s motion as a BVH file at ``path`` (``fps`` frames a second)."""
    angles = np.degrees(np.unwrap(euler_zxy(local_matrices(skeleton)), axis=0))  # (F, J, 3)
    children: dict[int, list[int]] = {j: [] for j in range(len(skeleton.names))}
    for j, parent in enumerate(skeleton.parents):
        if parent >= 0:
            children[int(parent)].append(j)
    lines = ["HIERARCHY"]

    def joint(j: int, depth: int) -> None:
        pad = "  " * depth
        root = skeleton.parents[j] < 0
        offset = np.zeros(3) if root else skeleton.offsets[j]
        lines.append(f"{pad}{'ROOT' if root else 'JOINT'} {skeleton.names[j]}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}  OFFSET {offset[0]:.6f} {offset[1]:.6f} {offset[2]:.6f}")
        channels = ROOT_CHANNELS if root else JOINT_CHANNELS
        lines.append(f"{pad}  CHANNELS {len(channels.split())} {channels}")
        for child in children[j]:
            joint(child, depth + 1)
        if not children[j]:
            end = np.asarray(END_SITES.get(skeleton.names[j], (0.0, 0.1, 0.0))) * skeleton.scale
            lines.append(f"{pad}  End Site")
            lines.append(f"{pad}  {{")
            lines.append(f"{pad}    OFFSET {end[0]:.6f} {end[1]:.6f} {end[2]:.6f}")
            lines.append(f"{pad}  }}")
        lines.append(f"{pad}}}")

    joint(int(np.flatnonzero(skeleton.parents < 0)[0]), 0)
    frames = len(skeleton.root_translation)
    lines += ["MOTION", f"Frames: {frames}", f"Frame Time: {1.0 / fps:.8f}"]
    # the channels in the order the hierarchy lists them (depth first, as written above)
    order: list[int] = []

    def walk(j: int) -> None:
        order.append(j)
        for child in children[j]:
            walk(child)

    walk(int(np.flatnonzero(skeleton.parents < 0)[0]))
    table = np.concatenate([skeleton.root_translation[:, None, :], angles[:, order]], axis=1).reshape(
        frames, -1
    )
    body = "\n".join(" ".join(f"{v:.5f}" for v in row) for row in table)
    path = Path(path)
    path.write_text("\n".join(lines) + "\n" + body + "\n")
    return path
