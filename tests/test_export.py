"""Motion out (issue 37): a 10 s schoolyard run written as .glb and .bvh and read back.

The joint positions are rebuilt from the files alone - the glTF by forward kinematics
over its nodes and animation (read with pygltflib), the BVH by an independent reader
(bvhio) - and compared with the nodes the simulation moved.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from twig_ecs.cli import main
from twig_ecs.export import bvh_paths, write
from twig_ecs.motion import BodyTrack, MotionRecorder
from twig_ecs.scene import Scene
from twig_ecs.skeleton import HUMANOID

pytestmark = pytest.mark.xdist_group("export")  # one worker simulates the run once

SECONDS = 10.0
MEDIAN_LIMIT, WORST_LIMIT = 0.01, 0.03  # m: the issue's 1 cm median, 3 cm worst
FIGURES = ("parent", "big_child", "small_child", "ragdoll")


@dataclass
class YardExport:
    tracks: dict[str, BodyTrack]
    glb: Path
    bvh: dict[str, Path]
    fps: int
    record_s: float
    write_s: float


@pytest.fixture(scope="module")
def yard(tmp_path_factory) -> YardExport:
    """The schoolyard run for 10 s, recorded at 30 fps and written as .glb and .bvh (timed)."""
    folder = tmp_path_factory.mktemp("export")
    with Scene.load("schoolyard") as scene:
        scene.step(0)  # kernels and systems ready before the clock starts
        t0 = time.perf_counter()
        recorder = MotionRecorder(scene, fps=30)
        recorder.run(SECONDS)
        t1 = time.perf_counter()
        glb = write(recorder, folder / "yard.glb")[0]
        bvh = write(recorder, folder / "yard.bvh")
        t2 = time.perf_counter()
    names = recorder.figures()
    assert bvh == bvh_paths(folder / "yard.bvh", names)
    return YardExport(recorder.tracks, glb, dict(zip(names, bvh, strict=True)), 30, t1 - t0, t2 - t1)


def _simulated(track: BodyTrack) -> np.ndarray:
    """(F, J, 3) the simulated node each joint sits on."""
    at = {name: k for k, name in enumerate(track.node_names)}
    return track.positions[:, [at[node] for _, node, *_ in HUMANOID]]


# -- reading the .glb back (pygltflib and plain numpy, nothing of twig_ecs) --------------


def _read(doc, blob: bytes, index: int) -> np.ndarray:
    acc = doc.accessors[index]
    view = doc.bufferViews[acc.bufferView]
    dtype = {5126: np.float32, 5125: np.uint32, 5121: np.uint8, 5123: np.uint16}[acc.componentType]
    width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4, "MAT4": 16}[acc.type]
    start = view.byteOffset + (acc.byteOffset or 0)
    return np.frombuffer(blob, dtype=dtype, count=acc.count * width, offset=start).reshape(acc.count, width)


def _quat_matrix(q: np.ndarray) -> np.ndarray:
    x, y, z, w = np.moveaxis(q, -1, 0)
    rows = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    return np.stack([np.stack(row, -1) for row in rows], -2)


@pytest.fixture(scope="module")
def gltf(yard):
    """The .glb read back: {figure: (F, J, 3) joint world positions}, and every rotation track."""
    import pygltflib

    doc = pygltflib.GLTF2().load_binary(str(yard.glb))
    blob = doc.binary_blob()
    frames = len(next(iter(yard.tracks.values())).frames)
    # every node's translation and rotation per frame: its own, or its animation's keys
    nodes = doc.nodes
    trans = np.array([n.translation or [0, 0, 0] for n in nodes], dtype=np.float64)[None].repeat(frames, 0)
    rot = np.array([n.rotation or [0, 0, 0, 1] for n in nodes], dtype=np.float64)[None].repeat(frames, 0)
    (animation,) = doc.animations
    rotations = []
    for channel in animation.channels:
        sampler = animation.samplers[channel.sampler]
        assert sampler.interpolation == "LINEAR"
        times = _read(doc, blob, sampler.input)[:, 0]
        assert np.allclose(times, np.arange(frames) / yard.fps, atol=1e-5)
        values = _read(doc, blob, sampler.output).astype(np.float64)
        if channel.target.path == "rotation":
            rot[:, channel.target.node] = values
            rotations.append(values)
        else:
            trans[:, channel.target.node] = values
    parent = {child: k for k, n in enumerate(nodes) for child in n.children}
    world_r = np.empty((frames, len(nodes), 3, 3))
    world_t = np.empty((frames, len(nodes), 3))
    for k in _parents_first(parent, len(nodes)):
        r = _quat_matrix(rot[:, k])
        if k in parent:
            p = parent[k]
            world_r[:, k] = world_r[:, p] @ r
            world_t[:, k] = world_t[:, p] + (world_r[:, p] @ trans[:, k, :, None])[..., 0]
        else:
            world_r[:, k], world_t[:, k] = r, trans[:, k]
    joints = {}
    for skin in doc.skins:
        joints[skin.name] = world_t[:, skin.joints]
        joints[skin.name + " rotations"] = world_r[:, skin.joints]
        ibm = _read(doc, blob, skin.inverseBindMatrices).reshape(-1, 4, 4)
        joints[skin.name + " bind"] = -ibm[:, 3, :3]  # column-major translations
    local = {node.name: rot[:, k] for k, node in enumerate(nodes)}
    return {"joints": joints, "rotations": rotations, "doc": doc, "local": local}


def _parents_first(parent: dict[int, int], count: int) -> list[int]:
    order, seen = [], set()

    def visit(k):
        if k in seen:
            return
        if k in parent:
            visit(parent[k])
        seen.add(k)
        order.append(k)

    for k in range(count):
        visit(k)
    return order


def _mirrored(track: BodyTrack) -> np.ndarray:
    """(F,) frames where the simulated pelvis has gone through to the front of the hip bar and
    mid-spine: a known fault of the torso's links (its five nodes lie nearly in one plane, so
    a mirror image keeps every link's length; session 19's note). No rotation of the rest
    pelvis puts a hip joint there, so those frames cannot match and are judged apart."""
    at = {name: k for k, name in enumerate(track.node_names)}

    def side(p: np.ndarray) -> np.ndarray:
        pelvis = p[..., at["pelvis"], :]
        edges = [p[..., at[n], :] - pelvis for n in ("l_hip", "r_hip", "spine")]
        return np.sign((np.cross(edges[0], edges[1]) * edges[2]).sum(-1))

    return side(track.positions) != side(track.rest)


def _errors(
    rebuilt: np.ndarray, simulated: np.ndarray, track: BodyTrack | None = None
) -> tuple[float, float]:
    e = np.linalg.norm(rebuilt - simulated, axis=-1)
    if track is not None:
        # (a doll lying on its back has it so throughout: the ground presses the pelvis up
        # level with the hips; its errors stay small, the doll being small)
        mirrored = _mirrored(track)
        standing = track.name != "ragdoll"
        assert not standing or mirrored.mean() < 0.1, (
            f"the pelvis through to the front in {mirrored.sum()} frames"
        )
        e = e[~mirrored] if standing else e
    return float(np.median(e)), float(e.max())


@pytest.mark.parametrize("figure", FIGURES)
def test_glb_joint_positions_rebuilt_from_rotations_match_the_simulated_nodes(yard, gltf, figure):
    median, worst = _errors(gltf["joints"][figure], _simulated(yard.tracks[figure]), yard.tracks[figure])
    print(f"glb {figure}: median {median * 100:.3f} cm, worst {worst * 100:.3f} cm")
    assert median < MEDIAN_LIMIT and worst < WORST_LIMIT


@pytest.mark.parametrize("figure", FIGURES)
def test_bvh_read_by_bvhio_matches_the_simulated_nodes(yard, figure):
    bvhio = pytest.importorskip("bvhio", reason="bvhio (the dev extra) reads the BVH back")
    root = bvhio.readAsHierarchy(str(yard.bvh[figure]))
    joints = {joint.Name: joint for joint, _, _ in root.layout()}
    simulated = _simulated(yard.tracks[figure])
    rebuilt = np.empty_like(simulated)
    for f in range(len(simulated)):
        root.loadPose(f)
        rebuilt[f] = [tuple(joints[name].PositionWorld) for name, *_ in HUMANOID]
    median, worst = _errors(rebuilt, simulated, yard.tracks[figure])
    print(f"bvh {figure}: median {median * 100:.3f} cm, worst {worst * 100:.3f} cm")
    assert median < MEDIAN_LIMIT and worst < WORST_LIMIT


def test_bvh_has_the_run_frame_count_and_the_cmu_channel_layout(yard):
    bvhio = pytest.importorskip("bvhio", reason="bvhio (the dev extra) reads the BVH back")
    container = bvhio.readAsBvh(str(yard.bvh["parent"]))
    assert container.FrameCount == int(SECONDS * yard.fps) + 1
    assert container.FrameTime == pytest.approx(1 / yard.fps)
    layouts = {joint.Name: list(joint.Channels) for joint, _, _ in container.Root.layout()}
    assert set(layouts) == {name for name, *_ in HUMANOID}
    assert layouts["Hips"] == ["Xposition", "Yposition", "Zposition", "Zrotation", "Xrotation", "Yrotation"]
    assert all(c == ["Zrotation", "Xrotation", "Yrotation"] for name, c in layouts.items() if name != "Hips")


@pytest.mark.parametrize("figure", ["parent", "big_child", "small_child"])
def test_the_head_faces_where_the_character_looks(yard, gltf, figure):
    head = [name for name, *_ in HUMANOID].index("Head")
    forward = gltf["joints"][figure + " rotations"][:, head] @ np.array([0.0, 0.0, 1.0])  # rest faces +z
    looks = yard.tracks[figure].face_directions
    angle = np.degrees(np.arccos(np.clip((forward * looks).sum(-1), -1.0, 1.0)))
    assert angle.max() < 1.0
    assert np.ptp(np.degrees(np.arctan2(looks[:, 0], looks[:, 2]))) > 20  # it did look about


def _knee_bends(track, side: str) -> np.ndarray:
    """The knee's bend (degrees) on ``side`` in every frame of a recorded track."""
    at = {name: k for k, name in enumerate(track.node_names)}
    p = track.positions
    hip, knee, foot = (at[f"{side}_{n}"] for n in ("hip", "knee", "foot"))
    thigh, shin = p[:, knee] - p[:, hip], p[:, foot] - p[:, knee]
    cosine = (thigh * shin).sum(-1) / np.linalg.norm(thigh, axis=-1) / np.linalg.norm(shin, axis=-1)
    return np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))


def test_a_straight_knee_exports_straight(yard, gltf):
    # the caregiver stands and watches these 10 s, on straight legs since issue 35 (before, its
    # knees stood bent 38-40 degrees and the hinge test below read them)
    for side in "lr":
        assert _knee_bends(yard.tracks["parent"], side).max() <= 10.0
        q = gltf["local"][f"parent:{'Left' if side == 'l' else 'Right'}Leg"]
        assert np.degrees(2.0 * np.arccos(np.clip(np.abs(q[:, 3]), 0.0, 1.0))).max() <= 12.0, side


@pytest.mark.parametrize("figure", ["big_child", "small_child"])
def test_a_bent_knee_turns_the_shin_about_the_knee_hinge_only(yard, gltf, figure):
    track = yard.tracks[figure]
    at = {name: k for k, name in enumerate(track.node_names)}
    p, rest = track.positions, track.rest
    for side in "lr":
        hip, knee, foot = (at[f"{side}_{n}"] for n in ("hip", "knee", "foot"))
        hinge = np.cross(rest[knee] - rest[hip], rest[foot] - rest[knee])  # the axis at rest: sideways
        hinge /= np.linalg.norm(hinge)
        thigh, shin = p[:, knee] - p[:, hip], p[:, foot] - p[:, knee]
        cosine = (thigh * shin).sum(-1) / np.linalg.norm(thigh, axis=-1) / np.linalg.norm(shin, axis=-1)
        bend = np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))
        q = gltf["local"][f"{figure}:{'Left' if side == 'l' else 'Right'}Leg"][bend > 25]
        axis = q[:, :3] / np.linalg.norm(q[:, :3], axis=-1, keepdims=True)
        off = np.degrees(np.arccos(np.clip(np.abs(axis @ hinge), 0.0, 1.0)))
        assert len(off) > 30 and off.max() < 1.0, (side, off.max())


def test_bone_lengths_stay_their_rest_lengths(gltf):
    for figure in FIGURES:
        joints, bind = gltf["joints"][figure], gltf["joints"][figure + " bind"]
        for j, (_, _, parent, *_) in enumerate(HUMANOID):
            if parent is None:
                continue
            p = [name for name, *_ in HUMANOID].index(parent)
            length = np.linalg.norm(joints[:, j] - joints[:, p], axis=-1)
            rest = np.linalg.norm(bind[j] - bind[p])
            assert np.abs(length - rest).max() < 1e-4, (figure, HUMANOID[j][0])


def test_no_rotation_track_flips_sign_between_frames(gltf):
    for values in gltf["rotations"]:
        assert np.allclose(np.linalg.norm(values, axis=-1), 1.0, atol=1e-5)
        assert ((values[1:] * values[:-1]).sum(-1) >= 0).all()


def test_glb_holds_the_props_as_animated_or_static_meshes_with_materials(gltf):
    doc = gltf["doc"]
    names = {n.name for n in doc.nodes}
    assert {"ball", "merry_go_round"} <= names  # moving props: animated nodes
    assert {s.name for s in doc.skins} == set(FIGURES)
    assert len(doc.materials) >= 5  # the three characters, the doll, the ball...


def test_a_ten_second_schoolyard_records_and_writes_in_under_ten_seconds(yard):
    # the issue's bound (wall time, kernels compiled); about 2.5 s on a loaded 2-core box
    print(f"recorded in {yard.record_s:.2f} s, wrote .glb and 4 .bvh in {yard.write_s:.2f} s")
    assert yard.record_s + yard.write_s < 10.0


VALIDATOR = Path.home() / ".cache" / "twig-ecs" / "gltf-validator"


def _validator() -> Path:
    """The Khronos glTF validator's npm package, installed once into a cache folder."""
    if shutil.which("node") is None or shutil.which("npm") is None:
        pytest.skip(
            "node and npm are not installed: the Khronos glTF validator (npm gltf-validator) cannot run"
        )
    module = VALIDATOR / "node_modules" / "gltf-validator"
    if not module.is_dir():
        VALIDATOR.mkdir(parents=True, exist_ok=True)
        done = subprocess.run(
            ["npm", "install", "--no-audit", "--no-fund", "--prefix", str(VALIDATOR), "gltf-validator"],
            capture_output=True,
            text=True,
            timeout=300,
        )
        if done.returncode != 0 or not module.is_dir():
            pytest.skip(f"could not install npm gltf-validator: {done.stderr.strip()[-300:]}")
    return module


def test_glb_passes_the_khronos_gltf_validator(yard):
    module = _validator()
    script = (
        "const v = require(process.argv[1]); const fs = require('fs');"
        "v.validateBytes(new Uint8Array(fs.readFileSync(process.argv[2])), {maxIssues: 50})"
        ".then(r => console.log(JSON.stringify(r.issues)))"
        ".catch(e => { console.error(String(e)); process.exit(1); });"
    )
    done = subprocess.run(
        ["node", "-e", script, str(module), str(yard.glb)], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    issues = json.loads(done.stdout)
    print(f"gltf-validator: {issues['numErrors']} errors, {issues['numWarnings']} warnings")
    assert issues["numErrors"] == 0, issues["messages"]


def test_export_to_an_unknown_extension_says_which_to_use(capsys, tmp_path):
    assert main(["export", "schoolyard", "-o", str(tmp_path / "out.fbx"), "--seconds", "0.1"]) == 2
    err = capsys.readouterr().err
    assert "error:" in err and ".glb" in err and ".bvh" in err
    assert not (tmp_path / "out.fbx").exists()


def test_export_of_an_unknown_character_names_the_ones_there_are_before_the_run(
    capsys, tmp_path, monkeypatch
):
    monkeypatch.setattr(MotionRecorder, "run", lambda *args, **kwargs: pytest.fail("it ran before checking"))
    out = tmp_path / "out.bvh"
    assert main(["export", "schoolyard", "-o", str(out), "--seconds", "0.1", "--character", "granny"]) == 2
    err = capsys.readouterr().err
    assert "'granny'" in err and "small_child" in err
    assert not out.exists()


def test_export_into_a_missing_folder_or_of_an_empty_scene_is_an_error(capsys, tmp_path):
    assert main(["export", "schoolyard", "-o", str(tmp_path / "no" / "yard.glb"), "--seconds", "0.1"]) == 2
    assert "no folder" in capsys.readouterr().err
    assert main(["export", "empty", "-o", str(tmp_path / "empty.glb"), "--seconds", "0.1"]) == 2
    assert "no bodies" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_export_of_one_character_writes_one_bvh(capsys, tmp_path):
    out = tmp_path / "kid.bvh"
    assert (
        main(["export", "schoolyard", "-o", str(out), "--seconds", "0.5", "--character", "small_child"]) == 0
    )
    assert out.read_text().startswith("HIERARCHY\nROOT Hips")
    assert "Frames: 16\n" in out.read_text()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kid.bvh"]


def test_export_continues_a_snapshot(tmp_path, capsys):
    snap = tmp_path / "yard.twig"
    with Scene.load("schoolyard") as scene:
        scene.run(0.5)
        scene_time = scene.time
        from twig_ecs.snapshot import save

        save(scene, snap)
    out = tmp_path / "from-snapshot.glb"
    assert main(["export", str(snap), "-o", str(out), "--seconds", "0.5"]) == 0
    assert out.stat().st_size > 0 and scene_time == pytest.approx(0.5, abs=0.02)


@pytest.mark.parametrize("shape", ["cylinder", "sphere"])
def test_mesh_triangles_face_outwards_and_none_is_degenerate(shape):
    from twig_ecs.gltfwriter import cylinder, sphere

    verts, normals, tris = (
        cylinder(np.zeros(3), np.array([0.0, 1.0, 0.0]), 0.1)
        if shape == "cylinder"
        else sphere(np.zeros(3), 0.11)
    )
    a, b, c = verts[tris[:, 0]], verts[tris[:, 1]], verts[tris[:, 2]]
    face = np.cross(b - a, c - a)  # glTF: counter-clockwise seen from the front
    assert (np.linalg.norm(face, axis=1) > 1e-9).all()
    assert ((face * normals[tris].sum(1)).sum(1) > 0).all()


def test_a_recorder_in_a_loop_of_ones_own_keeps_every_step_at_60_fps_and_refuses_other_rates(scenes):
    from twig_ecs.motion import MotionError

    scene = Scene.load("schoolyard")
    scenes.append(scene)
    with pytest.raises(MotionError, match="30, 60"):
        MotionRecorder(scene, fps=24)
    recorder = MotionRecorder(scene, fps=60)
    for _ in range(6):
        scene.step()
        recorder.capture()
    ball = recorder.tracks["ball"]
    assert recorder.frame_count == 7 and ball.positions.shape == (7, 1, 3)
    assert np.allclose(ball.positions[-1], scene.entity("ball").node_positions)
    assert recorder.figures() == list(FIGURES)


def test_export_replays_a_recorded_session_for_its_whole_length(tmp_path, capsys):
    head = {"twig_replay": 1, "scene": "schoolyard", "seed": 0, "content": [], "autonomous": True}
    session = tmp_path / "session.twigreplay"
    session.write_text(json.dumps(head) + "\n" + json.dumps({"end": 60, "state_hash": "x"}) + "\n")
    out = tmp_path / "replayed.bvh"
    assert main(["export", str(session), "-o", str(out), "--character", "small_child"]) == 0
    said = capsys.readouterr().out
    assert "schoolyard: 31 frames at 30 fps" in said  # 1 s: the start and 30 more, not --seconds' 10
    text = out.read_text()
    assert "Frames: 31" in text and "ROOT Hips" in text
