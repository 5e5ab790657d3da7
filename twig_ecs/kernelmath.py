"""Small numba helpers shared by the character controllers (scalar 3-vector math).

Controllers index a character's nodes by role through ``nodes[c, ROLE]``; the role
numbers below follow :data:`twig_ecs.store.ROLES`.

The helpers are plain ``@njit`` functions, not ``inline="always"``: numba inlines those
into every call site before typing it again, which made a first run's compile of the
controllers about twice as long (posture: 7.9 -> 3.5 s); LLVM still inlines the calls.
"""

from __future__ import annotations

import math

from twig_ecs.kernelcache import configure_cache

configure_cache()  # our cache locator first: numba binds a kernel's cache when it is decorated

from numba import njit  # noqa: E402
from numba.core.registry import CPUDispatcher  # noqa: E402

from twig_ecs.kernelcache import jit_disabled  # noqa: E402


class HelperKernel(CPUDispatcher):
    """A kernel compiled only for other kernels to call (:func:`kernel_helper`); called from
    Python, it runs as plain Python."""

    def __call__(self, *args, **kwargs):
        # compiled without Python's entry point: numba's would jump to a null address
        return self.py_func(*args, **kwargs)


def kernel_helper(function=None, **options):
    """``@kernel_helper`` (or ``@kernel_helper(nogil=True, ...)``): ``@njit(cache=True)`` for a
    kernel that only other kernels call.

    Numba gives every compiled kernel an entry point for Python - code that unboxes each
    argument from a Python object and boxes the result - lowered and optimised by LLVM with
    the kernel. When the first 37 helpers lost theirs, a first run's compile lost about a tenth
    (about 2 s of CPU in one process); a helper is compiled without one. Called from Python (a test, a
    debugger) it runs as plain Python, its ``py_func``: the same arithmetic, slower.
    ``tests/test_first_run.py`` checks that no code of ours calls one from Python.
    """

    def decorate(py_func):
        if jit_disabled():
            return py_func
        kernel = HelperKernel(
            py_func, targetoptions={"nopython": True, "no_cpython_wrapper": True, **options}
        )
        kernel.enable_caching()
        return kernel

    return decorate(function) if function is not None else decorate


PELVIS, SPINE, NECK, HEAD, L_HIP, R_HIP, L_KNEE, R_KNEE = 0, 1, 2, 3, 4, 5, 6, 7
L_FOOT, R_FOOT, L_SHOULDER, R_SHOULDER, L_ELBOW, R_ELBOW, L_HAND, R_HAND = 8, 9, 10, 11, 12, 13, 14, 15

# posture modes (CHARACTER_FIELDS["mode"])
STAND, SIT, RISE, LIMP = 0, 1, 2, 3

# arm modes (CHARACTER_FIELDS["arm_mode"]), see systems/control/arms.py
HANG, REACH, GRAPPLE, HUG, WAVE, POINT, CARRY = 0, 1, 2, 3, 4, 5, 6
ARM_MODES = {"hang": HANG, "reach": REACH, "grapple": GRAPPLE, "hug": HUG, "wave": WAVE, "point": POINT,
             "carry": CARRY}  # fmt: skip

# gaze modes (CHARACTER_FIELDS["gaze_mode"]), see systems/control/gaze.py: where the head turns to
GAZE_AHEAD, GAZE_POINT, GAZE_NODE = 0, 1, 2  # the way it walks (or faces); gaze_point; gaze_node


# -- the walk's and the run's proportions (dynamic similarity, docs/locomotion.md) ------
#: Froude number v^2 / (g L) where the walk gives way to a run (a person changes near 0.5).
WALK_FROUDE_MAX = 0.5
#: Froude number the gait caps the run at: the one place the top speed per body size is
#: decided (2.8 m/s for a 1.05 m child, 3.6 m/s for an adult).
RUN_FROUDE_MAX = 1.5
#: Step length / leg length = STEP_GAIN * Froude ** STEP_POWER (a person: 0.7-0.8 at 1.2 m/s).
STEP_GAIN, STEP_POWER = 1.25, 0.3
#: Running, step / leg = RUN_STEP_GAIN * (Froude / WALK_FROUDE_MAX) ** RUN_STEP_POWER: shorter
#: than the walk's at the transition, quicker (a person running 2.5 m/s: 2.6-3.0 steps/s of
#: ~0.9 m, about a leg length).
RUN_STEP_GAIN, RUN_STEP_POWER = 0.88, 0.5
#: Longest step period (s) per sqrt(L / g): people shuffle rather than step slower.
MAX_STEP_PERIOD = 2.6


@kernel_helper
def walk_speed(speed, leg, g):
    """The pace a body with legs ``leg`` m long takes when asked for ``speed``: capped at the
    run's Froude limit (the one place the top speed per body size is decided)."""
    return min(speed, math.sqrt(RUN_FROUDE_MAX * g * leg))


#: Share of a step period a foot is in the air: walking (both feet down the rest, ~20%),
#: running (both up the last 0.2: the flight), blended over RUN_BLEND of Froude number
#: round the transition so that a pace hovering at it does not switch gaits step by step.
WALK_SHARE, RUN_SHARE, RUN_BLEND = 0.8, 1.2, 0.15


@kernel_helper
def run_share(speed, leg, g):
    """How much of a run a pace of ``speed`` (already capped) is: 0 walking, 1 running,
    blended over RUN_BLEND of Froude number round the transition (the flight, the run's
    steps, its arms and its lean all come in together)."""
    fr = speed * speed / (g * leg)
    return min(1.0, max(0.0, (fr - (WALK_FROUDE_MAX - 0.5 * RUN_BLEND)) / RUN_BLEND))


@kernel_helper
def swing_share(speed, leg, g):
    """How long a foot is in the air per step period at a pace of ``speed`` (already capped):
    under 1 it walks (a double support), over 1 it runs (a flight)."""
    return WALK_SHARE + (RUN_SHARE - WALK_SHARE) * run_share(speed, leg, g)


@kernel_helper
def step_length(speed, leg, g):
    """Step length (m) at a pace of ``speed`` (already capped) for legs ``leg`` m long."""
    fr = speed * speed / (g * leg)
    by_froude = leg * STEP_GAIN * fr**STEP_POWER
    # very slow: a step never takes longer than MAX_STEP_PERIOD natural times
    walk = min(by_froude, speed * MAX_STEP_PERIOD * math.sqrt(leg / g))
    # running, shorter steps at a quicker cadence than the walk's, blended in over the
    # transition as the flight is (swing_share)
    k = run_share(speed, leg, g)
    if k <= 0.0:
        return walk
    run = leg * RUN_STEP_GAIN * (fr / WALK_FROUDE_MAX) ** RUN_STEP_POWER
    return walk + (run - walk) * k


@kernel_helper
def forward_xz(pos, left, right):
    """Unit ground-plane forward of a left/right node pair: (left - right) x up."""
    lx = pos[left, 0] - pos[right, 0]
    lz = pos[left, 2] - pos[right, 2]
    n = math.sqrt(lx * lx + lz * lz)
    if n < 1e-9:
        return 0.0, 1.0
    return -lz / n, lx / n


@kernel_helper
def yaw_error(fx, fz, dx, dz):
    """Signed angle (rad) turning ground direction f onto d about +y (+: towards +x from +z)."""
    return math.atan2(fz * dx - fx * dz, fx * dx + fz * dz)


@njit(cache=True)
def clamp(x, lo, hi):
    """x limited to [lo, hi]."""
    return lo if x < lo else (hi if x > hi else x)


@njit(cache=True)
def approach_field(px, pz, gx, gz, obstacles, n_obstacles, speed, repulsion, cutoff, min_sq, curl, fade):
    """The approach walk vector ``w = a + r`` on the ground plane (SPEC 4); returns (wx, wz).

    ``a``: towards the goal (gx, gz), saturated at ``speed`` and slowing over the last
    metre. ``r = sum c ((p - o) + (p - o) x e_y) / max(d_min, |p - o|^2)`` over the first
    ``n_obstacles`` rows of ``obstacles`` nearer than ``cutoff``, fading out within
    ``fade`` m of the goal; ``w`` is capped at ``speed``. The one implementation of the
    field: the steering kernel (:func:`twig_ecs.systems.control.steer.steer_rows`) calls it
    for every walker, one character's or a crowd's.
    """
    ax = gx - px
    az = gz - pz
    dist = math.sqrt(ax * ax + az * az)
    if dist > 1e-9:
        k = min(speed, speed * dist)
        ax = ax / dist * k
        az = az / dist * k
    else:
        ax = 0.0
        az = 0.0
    rx = 0.0
    rz = 0.0
    cut_sq = cutoff * cutoff
    for o in range(n_obstacles):
        ox = px - obstacles[o, 0]
        oz = pz - obstacles[o, 2]
        sq = ox * ox + oz * oz
        if sq >= cut_sq:
            continue
        ux = ox
        uz = oz
        if curl:  # (p - o) x e_y = (-(p - o)_z, 0, (p - o)_x): the sideways push
            ux = ox - oz
            uz = oz + ox
        m = max(min_sq, sq)
        rx += repulsion * ux / m
        rz += repulsion * uz / m
    # near the goal the push fades (quadratically: a grown-up standing by a ball would
    # otherwise keep a child circling it), so a crowd cannot hold one off a metre short
    f = min(1.0, dist / fade) ** 2
    wx = ax + rx * f
    wz = az + rz * f
    w = math.sqrt(wx * wx + wz * wz)
    if w > speed:
        wx *= speed / w
        wz *= speed / w
    return wx, wz
