"""MuJoCo's side of the comparison: piles of capsule humanoid ragdolls, stepped at 1/60 s.

Each ragdoll is built like our ``humanoid`` (1.75 m): a pelvis bar with a free joint,
two spine capsules, a shoulder bar, a head, two-segment arms and legs - 13 capsules on
11 bodies, ball joints at hips, shoulders, spine and neck, hinges at knees and
elbows. They are laid out as :func:`twig_ecs.bench.cases.ragdoll_pile` lays out ours
(a square grid 1.2 m apart, dropped from 0.5-2 m, random facings) on a plane. MuJoCo's
default solver settings are kept; only the time step is ours. Needs the optional
``bench`` extra (``pip install 'twig-ecs[bench]'``).
"""

from __future__ import annotations

import hashlib
import math
import os
import tempfile
import time
from pathlib import Path

import numpy as np

#: Capsule radius (m) of limbs, torso and head: about our humanoid's (the arms hang
#: clear of the pelvis and legs: MuJoCo collides a ragdoll's own non-adjacent capsules).
LIMB, TORSO, HEAD = 0.05, 0.09, 0.1


def _ragdoll(k: int, x: float, y: float, z: float, yaw: float) -> str:
    """MJCF of one ragdoll (MuJoCo is z-up: our ground (x, z) is its (x, y))."""
    q = f"{math.cos(yaw / 2):.6f} 0 0 {math.sin(yaw / 2):.6f}"

    def limb(name: str, at: str, length: float, hinge_axis: str) -> str:
        """A two-capsule limb hanging from ``at``: ball joint on top, hinge in the middle."""
        return (
            f'<body name="{name}{k}" pos="{at}">'
            f'<joint type="ball" damping="0.5"/>'
            f'<geom type="capsule" fromto="0 0 0 0 0 {-length:.3f}" size="{LIMB}"/>'
            f'<body pos="0 0 {-length:.3f}">'
            f'<joint type="hinge" axis="{hinge_axis}" range="0 150" damping="0.5"/>'
            f'<geom type="capsule" fromto="0 0 0 0 0 {-length:.3f}" size="{LIMB}"/></body></body>'
        )

    return (
        f'<body name="pelvis{k}" pos="{x:.3f} {z:.3f} {y + 1.0:.3f}" quat="{q}"><freejoint/>'
        f'<geom type="capsule" fromto="-0.1 0 0 0.1 0 0" size="{LIMB + 0.02}"/>'
        f'<body name="spine{k}" pos="0 0 0.1"><joint type="ball" damping="1"/>'
        f'<geom type="capsule" fromto="0 0 0 0 0 0.22" size="{TORSO}"/>'
        f'<body name="chest{k}" pos="0 0 0.22"><joint type="ball" damping="1"/>'
        f'<geom type="capsule" fromto="0 0 0 0 0 0.2" size="{TORSO}"/>'
        f'<geom type="capsule" fromto="-0.2 0 0.2 0.2 0 0.2" size="{LIMB}"/>'
        f'<body name="head{k}" pos="0 0 0.28"><joint type="ball" damping="0.5"/>'
        f'<geom type="capsule" fromto="0 0 0.02 0 0 0.14" size="{HEAD}"/></body>'
        + limb("larm", "-0.25 0 0.2", 0.28, "0 1 0")
        + limb("rarm", "0.25 0 0.2", 0.28, "0 1 0")
        + "</body></body>"
        + limb("lleg", "-0.1 0 -0.05", 0.42, "1 0 0")
        + limb("rleg", "0.1 0 -0.05", 0.42, "1 0 0")
        + "</body>"
    )


def ragdolls_mjcf(count: int, dt: float = 1.0 / 60.0, seed: int = 1) -> str:
    """An MJCF model of ``count`` ragdolls on a plane, laid out like our ragdoll pile."""
    side = math.ceil(math.sqrt(count))
    rng = np.random.default_rng(seed)
    bodies = []
    for k in range(count):
        x, z = (k % side) * 1.2, (k // side) * 1.2
        y = float(rng.uniform(0.5, 2.0))
        yaw = math.radians(float(rng.uniform(0, 360)))
        bodies.append(_ragdoll(k, x, y, z, yaw))
    extent = side * 1.2 + 10
    return (
        f'<mujoco model="ragdolls"><option timestep="{dt:.8f}" integrator="implicitfast"/>'
        # armature and joint damping keep light limbs stable at a 1/60 s step
        '<default><geom density="1000" friction="0.8"/><joint armature="0.02"/></default>'
        f'<size memory="{max(64, 2 * count)}M"/>'
        f'<worldbody><geom type="plane" size="{extent} {extent} 0.1"/>'
        + "".join(bodies)
        + "</worldbody></mujoco>"
    )


def available() -> bool:
    """Is MuJoCo installed (the ``bench`` extra)?"""
    try:
        import mujoco  # noqa: F401
    except ImportError:
        return False
    return True


#: Compiled models kept in the cache (the newest; a 1000-ragdoll model is ~28 MB on disk).
KEEP_MODELS = 4


def model_cache() -> Path:
    """Where compiled models are kept: ``mujoco-models`` in twig's cache folder
    (``TWIG_CACHE_DIR`` or the user cache dir), beside the kernels."""
    from twig_ecs.kernelcache import cache_base

    return cache_base() / "mujoco-models"


#: The most ragdolls the bench has MuJoCo compile a model of (its compiler's time grows with
#: the square of the bodies: 1000 ragdolls ~70 s on a 2-core box, so 2000 ~5 min, 10 000 hours);
#: a larger model is used only when it is in the cache already.
COMPILE_LIMIT = 2000


def _model_path(mjcf: str) -> Path:
    import mujoco

    key = hashlib.sha256(f"{mujoco.__version__}\n{mjcf}".encode()).hexdigest()[:16]
    return model_cache() / f"ragdolls-{key}.mjb"


def affordable(count: int, dt: float = 1.0 / 60.0) -> bool:
    """Can the bench have a MuJoCo model of ``count`` ragdolls soon: at most
    :data:`COMPILE_LIMIT`, or compiled before and cached?"""
    return count <= COMPILE_LIMIT or _model_path(ragdolls_mjcf(count, dt)).exists()


def compiled_model(mjcf: str):
    """MuJoCo's model of ``mjcf`` and whether it came from the cache.

    MuJoCo 4's compiler takes time quadratic in the bodies (1000 ragdolls: over a minute
    on a quiet 2-core box, 10 000: hours), so a compiled model is saved (MJB, MuJoCo's
    binary model: the same model, stepping to the same bits) under a hash of its MJCF and
    MuJoCo's version and loaded from there next time (a fraction of a second).
    """
    import mujoco

    path = _model_path(mjcf)
    folder = path.parent
    if path.exists():
        try:
            os.utime(path)  # in use: kept by the pruning below
            return mujoco.MjModel.from_binary_path(str(path)), True
        except (OSError, ValueError):
            pass  # unreadable or from another build: compile again
    model = mujoco.MjModel.from_xml_string(mjcf)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=folder, suffix=".part", delete=False) as f:
            part = Path(f.name)
        mujoco.mj_saveModel(model, str(part), None)
        part.replace(path)  # whole or not at all: another bench may be reading
        old = sorted(folder.glob("ragdolls-*.mjb"), key=lambda p: p.stat().st_mtime)
        for stale in old[:-KEEP_MODELS]:
            stale.unlink(missing_ok=True)
    except OSError:
        pass  # no cache: compiled again next time
    return model, False


class Ragdolls:
    """A MuJoCo model of ``count`` ragdolls that steps one ``mj_step`` at a time, timed."""

    def __init__(self, count: int, dt: float = 1.0 / 60.0) -> None:
        import mujoco

        self._mujoco = mujoco
        t0 = time.perf_counter()
        self.model, self.cached = compiled_model(ragdolls_mjcf(count, dt))
        self.build_s = time.perf_counter() - t0
        self.data = mujoco.MjData(self.model)

    def reset(self) -> None:
        """Back to the start: the ragdolls in the air."""
        self._mujoco.mj_resetData(self.model, self.data)

    def step(self) -> float:
        """One step; returns its wall time (s)."""
        t0 = time.perf_counter()
        self._mujoco.mj_step(self.model, self.data)
        return time.perf_counter() - t0

    def info(self) -> dict:
        """Size of the model and how the simulation fares."""
        m, d = self.model, self.data
        return {
            "bodies": int(m.nbody - 1),
            "geoms": int(m.ngeom - 1),
            "dofs": int(m.nv),
            "contacts": int(d.ncon),
            # MuJoCo resets a diverging simulation itself and counts it as a warning
            "unstable": int(d.warning[self._mujoco.mjtWarning.mjWARN_BADQACC].number),
            "build_s": self.build_s,  # compiling the model, or loading it (cached)
            "cached": self.cached,
            "version": self._mujoco.__version__,
        }
