"""glTF 2.0 binary (.glb) output of a recorded run, written with pygltflib.

What maps to what:

- every figure (a body with the humanoid nodes: the characters and the ragdoll) is a
  skin: the joint hierarchy of :mod:`twig_ecs.skeleton` as nodes (bind pose = the rest
  pose, inverse bind matrices = the joints' rest positions negated), over one mesh of its
  visible capsules (closed cylinders), each rigidly bound to the bone it belongs to;
- a body that moves but has no skeleton (the ball, the merry-go-round) is a node animated
  by the rigid motion that best fits its nodes (Kabsch), its mesh in its first frame's pose;
- a body that never moves (fences, posts, benches) is a mesh in place;
- colours become materials (one per colour); units are metres, +Y is up, as glTF asks;
- one animation for the run: a rotation channel per joint and per moving body, a
  translation channel per root and per moving body, LINEAR, 30 or 60 keys a second.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pygltflib as gl

from twig_ecs.motion import BodyTrack
from twig_ecs.skeleton import HUMANOID, LINK_JOINTS, Skeleton, continuous, quaternions

FLOAT, UNSIGNED_INT, UNSIGNED_BYTE = 5126, 5125, 5121
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
#: Sides of a capsule's cylinder and of a ball's sphere.
SEGMENTS = 12


def cylinder(a: np.ndarray, b: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices, normals and triangle indices of a closed cylinder of ``radius`` from ``a`` to ``b``."""
    axis = b - a
    length = float(np.linalg.norm(axis))
    u = axis / length if length > 1e-9 else np.array([0.0, 1.0, 0.0])
    side = np.cross(u, [1.0, 0.0, 0.0] if abs(u[0]) < 0.9 else [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    other = np.cross(u, side)
    t = np.linspace(0.0, 2.0 * np.pi, SEGMENTS, endpoint=False)
    ring = np.cos(t)[:, None] * side + np.sin(t)[:, None] * other  # (S, 3) unit outward
    n = SEGMENTS
    # side walls (rings at both ends, outward normals), then the two caps (own normals)
    verts = np.concatenate(
        [a + radius * ring, b + radius * ring, a + radius * ring, b + radius * ring, [a, b]]
    )
    normals = np.concatenate([ring, ring, np.tile(-u, (n, 1)), np.tile(u, (n, 1)), [-u, u]])
    k = np.arange(n)
    k1 = (k + 1) % n
    tris = [
        np.stack([k, k1, n + k1], 1),
        np.stack([k, n + k1, n + k], 1),
        np.stack([np.full(n, 4 * n), 2 * n + k1, 2 * n + k], 1),
        np.stack([np.full(n, 4 * n + 1), 3 * n + k, 3 * n + k1], 1),
    ]
    return verts, normals, np.concatenate(tris)


def sphere(centre: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices, normals and triangle indices of a UV sphere."""
    rows, cols = SEGMENTS // 2 + 1, SEGMENTS
    theta = np.linspace(0.0, np.pi, rows)[:, None]
    phi = np.linspace(0.0, 2.0 * np.pi, cols, endpoint=False)[None, :]
    normals = np.stack(
        [np.sin(theta) * np.cos(phi), np.cos(theta) * np.ones_like(phi), np.sin(theta) * np.sin(phi)], -1
    ).reshape(-1, 3)
    r, c = np.meshgrid(np.arange(rows - 1), np.arange(cols), indexing="ij")
    a, b = r * cols + c, r * cols + (c + 1) % cols
    # counter-clockwise seen from outside (glTF's front faces); none at the poles, where a
    # row's vertices all coincide
    upper = np.stack([a, b, a + cols], -1)[1:].reshape(-1, 3)
    lower = np.stack([b, b + cols, a + cols], -1)[:-1].reshape(-1, 3)
    tris = np.concatenate([upper, lower])
    return centre + radius * normals, normals, tris


class _Builder:
    """Collects buffer views, accessors and materials into one binary buffer."""

    def __init__(self) -> None:
        self.doc = gl.GLTF2(asset=gl.Asset(generator="twig-ecs export", version="2.0"))
        self.doc.scenes = [gl.Scene(nodes=[])]
        self.doc.scene = 0
        self.blob = bytearray()
        self.materials: dict[tuple[float, ...], int] = {}

    def accessor(
        self, data: np.ndarray, kind: str, component: int, target: int | None = None, bounds: bool = False
    ) -> int:
        """Append ``data`` to the buffer as a new accessor of ``kind`` (SCALAR, VEC3, MAT4...)."""
        while len(self.blob) % 4:
            self.blob.append(0)
        raw = np.ascontiguousarray(data).tobytes()
        self.doc.bufferViews.append(
            gl.BufferView(buffer=0, byteOffset=len(self.blob), byteLength=len(raw), target=target)
        )
        self.blob += raw
        count = len(data)
        extra = {}
        if bounds:
            flat = np.asarray(data, dtype=np.float64).reshape(count, -1)
            extra = {"min": flat.min(0).tolist(), "max": flat.max(0).tolist()}
        self.doc.accessors.append(
            gl.Accessor(
                bufferView=len(self.doc.bufferViews) - 1,
                componentType=component,
                count=count,
                type=kind,
                **extra,
            )
        )
        return len(self.doc.accessors) - 1

    def material(self, rgba: tuple[float, ...]) -> int:
        """The index of the material of colour ``rgba`` (made once)."""
        key = tuple(round(float(c), 4) for c in rgba)
        if key not in self.materials:
            pbr = gl.PbrMetallicRoughness(baseColorFactor=list(key), metallicFactor=0.0, roughnessFactor=0.8)
            self.doc.materials.append(
                gl.Material(name=f"colour {len(self.materials)}", pbrMetallicRoughness=pbr)
            )
            self.materials[key] = len(self.doc.materials) - 1
        return self.materials[key]

    def node(self, node: gl.Node, root: bool = False) -> int:
        """Add a node (to the scene's roots when ``root``) and return its index."""
        self.doc.nodes.append(node)
        if root:
            self.doc.scenes[0].nodes.append(len(self.doc.nodes) - 1)
        return len(self.doc.nodes) - 1

    def mesh(self, name: str, parts: list[tuple[tuple, tuple, int | None]]) -> int:
        """A mesh of ``parts`` (rgba, (verts, normals, tris), joint or None), one primitive per colour."""
        by_colour: dict[tuple, list] = {}
        for rgba, geometry, joint in parts:
            by_colour.setdefault(tuple(rgba), []).append((geometry, joint))
        primitives = []
        for rgba, items in by_colour.items():
            verts, normals, tris, joints, start = [], [], [], [], 0
            for (v, n, t), joint in items:
                verts.append(v)
                normals.append(n)
                tris.append(t + start)
                joints.append(np.full(len(v), -1 if joint is None else joint))
                start += len(v)
            v = np.concatenate(verts).astype(np.float32)
            attributes = gl.Attributes(
                POSITION=self.accessor(v, "VEC3", FLOAT, ARRAY_BUFFER, bounds=True),
                NORMAL=self.accessor(np.concatenate(normals).astype(np.float32), "VEC3", FLOAT, ARRAY_BUFFER),
            )
            j = np.concatenate(joints)
            if (j >= 0).all():
                four = np.zeros((len(j), 4), dtype=np.uint8)
                four[:, 0] = j
                weights = np.zeros((len(j), 4), dtype=np.float32)
                weights[:, 0] = 1.0
                attributes.JOINTS_0 = self.accessor(four, "VEC4", UNSIGNED_BYTE, ARRAY_BUFFER)
                attributes.WEIGHTS_0 = self.accessor(weights, "VEC4", FLOAT, ARRAY_BUFFER)
            indices = self.accessor(
                np.concatenate(tris).astype(np.uint32).reshape(-1),
                "SCALAR",
                UNSIGNED_INT,
                ELEMENT_ARRAY_BUFFER,
            )
            primitives.append(
                gl.Primitive(attributes=attributes, indices=indices, material=self.material(rgba))
            )
        self.doc.meshes.append(gl.Mesh(name=name, primitives=primitives))
        return len(self.doc.meshes) - 1


def _shapes(track: BodyTrack, pose: np.ndarray) -> list[tuple[tuple, tuple, tuple[str, str]]]:
    """The visible capsules and spheres of ``track`` in ``pose`` (n, 3): (rgba, geometry, its nodes)."""
    out = []
    for a, b, radius, rgba in track.links:
        out.append((rgba, cylinder(pose[a], pose[b], radius), (track.node_names[a], track.node_names[b])))
    for k in np.flatnonzero(track.sphere):
        name = track.node_names[k]
        out.append((track.color, sphere(pose[k], float(track.radius[k])), (name, name)))
    return out


def _rigid(track: BodyTrack) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The body's first-frame centroid and, per frame, the best rigid rotation and translation (Kabsch)."""
    p = track.positions
    c0 = p[0].mean(0)
    c = p.mean(1)
    if p.shape[1] < 2:
        return c0, np.broadcast_to(np.eye(3), (len(p), 3, 3)), c
    h = np.einsum("ki,fkj->fij", p[0] - c0, p - c[:, None])  # covariance of rest -> now
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(np.swapaxes(vt, -1, -2) @ np.swapaxes(u, -1, -2)))
    fix = np.broadcast_to(np.eye(3), h.shape).copy()
    fix[:, 2, 2] = d
    r = np.swapaxes(vt, -1, -2) @ fix @ np.swapaxes(u, -1, -2)
    return c0, r, c


def write_glb(tracks: list[BodyTrack], skeletons: dict[str, Skeleton], path: str | Path, fps: int) -> Path:
    """Write the recorded ``tracks`` as a .glb at ``path``; bodies named in ``skeletons`` are skinned."""
    out = _Builder()
    frames = len(tracks[0].frames)  # every track has the first frame at least
    times: list[int] = []  # the key times' accessor, made with the first channel
    channels, samplers = [], []

    def animate(node: int, path: str, values: np.ndarray) -> None:
        kind = "VEC4" if values.shape[-1] == 4 else "VEC3"
        if not times:
            times.append(
                out.accessor((np.arange(frames) / fps).astype(np.float32), "SCALAR", FLOAT, bounds=True)
            )
        samplers.append(
            gl.AnimationSampler(
                input=times[0],
                output=out.accessor(values.astype(np.float32), kind, FLOAT),
                interpolation="LINEAR",
            )
        )
        channels.append(
            gl.AnimationChannel(
                sampler=len(samplers) - 1, target=gl.AnimationChannelTarget(node=node, path=path)
            )
        )

    for track in tracks:
        skeleton = skeletons.get(track.name)
        if skeleton is not None:
            _add_figure(out, track, skeleton, animate)
        elif track.is_static():
            parts = [(rgba, geo, None) for rgba, geo, _ in _shapes(track, track.frames[0])]
            if parts:
                out.node(gl.Node(name=track.name, mesh=out.mesh(track.name, parts)), root=True)
        else:
            c0, rot, centre = _rigid(track)
            parts = [(rgba, geo, None) for rgba, geo, _ in _shapes(track, track.frames[0] - c0)]
            q = continuous(quaternions(rot))
            node = out.node(
                gl.Node(
                    name=track.name,
                    mesh=out.mesh(track.name, parts) if parts else None,
                    translation=centre[0].tolist(),
                    rotation=q[0].tolist(),
                ),
                root=True,
            )
            animate(node, "translation", centre)
            animate(node, "rotation", q)
    if channels:
        out.doc.animations.append(gl.Animation(name="twig run", channels=channels, samplers=samplers))
    assert out.blob, "a scene with no bodies has nothing to write (glTF forbids an empty buffer)"
    out.doc.buffers.append(gl.Buffer(byteLength=len(out.blob)))
    out.doc.set_binary_blob(bytes(out.blob))
    path = Path(path)
    out.doc.save_binary(str(path))
    return path


def _add_figure(out: _Builder, track: BodyTrack, skeleton: Skeleton, animate) -> None:
    """A figure as joint nodes, a skin and a skinned mesh of its capsules; its channels via ``animate``."""
    first = len(out.doc.nodes)
    joint_of = {name: k for k, name in enumerate(skeleton.names)}
    node_joint = {}  # node name -> the joint sitting on it (the first: Chest before the clavicles)
    for name, (_, node, *_rest) in zip(skeleton.names, HUMANOID, strict=True):
        node_joint.setdefault(node, joint_of[name])
    for j, name in enumerate(skeleton.names):
        translation = skeleton.root_translation[0] if skeleton.parents[j] < 0 else skeleton.offsets[j]
        out.node(
            gl.Node(
                name=f"{track.name}:{name}",
                translation=[float(v) for v in translation],
                rotation=[float(v) for v in skeleton.local[0, j]],
            ),
            root=skeleton.parents[j] < 0,
        )
    for j, parent in enumerate(skeleton.parents):
        if parent >= 0:
            out.doc.nodes[first + parent].children.append(first + j)
    ibm = np.tile(np.eye(4, dtype=np.float32), (len(skeleton.names), 1, 1))
    ibm[:, 3, :3] = -skeleton.bind  # column-major: the translation is the 4th column, stored as a row
    skin = gl.Skin(
        name=track.name,
        joints=list(range(first, first + len(skeleton.names))),
        inverseBindMatrices=out.accessor(ibm.reshape(-1, 16), "MAT4", FLOAT),
        skeleton=first,
    )
    out.doc.skins.append(skin)
    parts = []
    for rgba, geometry, ends in _shapes(track, track.rest):
        joint = LINK_JOINTS.get(ends, LINK_JOINTS.get(ends[::-1]))
        parts.append((rgba, geometry, joint_of[joint] if joint else node_joint.get(ends[0], 0)))
    head = [
        radius
        for a, b, radius, _ in track.links
        if {track.node_names[a], track.node_names[b]} == {"neck", "head"}
    ]
    if track.faces is not None and head:  # a nose, as twig draws it, shows where the face points
        centre, r = track.rest[track.node_names.index("head")], head[0]
        nose = cylinder(centre + [0.0, 0.0, 0.55 * r], centre + [0.0, -0.12 * r, 1.22 * r], 0.2 * r)
        parts.append((track.color, nose, joint_of["Head"]))
    out.node(
        gl.Node(name=f"{track.name} body", mesh=out.mesh(track.name, parts), skin=len(out.doc.skins) - 1),
        root=True,
    )
    animate(first, "translation", skeleton.root_translation)
    for j in range(len(skeleton.names)):
        animate(first + j, "rotation", skeleton.local[:, j])
