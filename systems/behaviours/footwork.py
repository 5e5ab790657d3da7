"""footwork: turning on the spot and stepping backwards, for behaviours that place the feet.

The gait steps where the walk goes, always facing it, and standing it only damps the
pelvis's turn. A behaviour that must turn its back to a seat (``sit``) or walk backwards
facing what it pulls (``drag``) uses these: :func:`pivot` turns the hips and lets the
gait's standing steps bring the feet round; :func:`step_back` sends the feet itself, on
the kick's ballistic arc (:func:`~twig_ecs.systems.behaviours.kick.launch_kick`), holding
the gait's steps off by the feet's step timers. Plain Python on one character: rare.
"""

from __future__ import annotations

import math

import numpy as np

from twig_ecs.store import NODE_LOCKED
from twig_ecs.systems.behaviours.kick import FEET, launch_kick

TURN_RATE = 2.5  # rad/s the hips pivot at (the feet step round after them, as standing steps do)
TURN_GAIN = 60.0  # 1/s: the pivot's yaw velocity servo
YAW_DAMP = 60.0  # 1/s: what posture's yaw control damps a standing pelvis's turn with (added back)
TURNED = math.cos(math.radians(20.0))  # facing this near the way wanted: turned
BACK_STEP_TIME = 0.32  # s a backward step is in the air (at 1.75 m, by the root of the size)
BACK_REACH = 0.97  # of the leg's length: the farthest from its hip a backward step lands
BACK_PAUSE = 0.06  # s both feet down between backward steps at the least (braced; 0.1 before the
# reach cut strides short: the fastest drag then went 0.35 m/s, under the pace it can step)
#: of a stride: how far the feet's middle, and the pelvis over it, move back with each step
#: (measured: the pelvis lags the feet, so a step lands short of a stride behind the other;
#: 2/3 on the crouched gait, 0.9 on straight legs: the doll dragged at 0.25 m/s went 0.24)
BACK_SHIFT = 0.9


def flat_unit(v: np.ndarray) -> np.ndarray:
    """``v`` on the ground plane, of length 1 (zero if it has none)."""
    v = np.asarray(v, dtype=np.float64) * np.array([1.0, 0.0, 1.0])
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-9 else np.zeros(3)


def pivot(character, facing: np.ndarray) -> bool:
    """Turn the hips on the spot towards the ground direction ``facing``; True once there.

    Standing still, the posture controller only damps the pelvis's yaw; this adds the
    turn (opposite accelerations on the torso about the pelvis, as posture's own yaw
    control does), at ``TURN_RATE``, and the gait's standing steps bring the feet round
    under the hips. The face and shoulders look the way it turns first.
    """
    f = character.facing
    cos = float(f @ facing)
    if cos > TURNED:
        return True
    sin = float(f[2] * facing[0] - f[0] * facing[2])  # + : turn left (towards +x from +z)
    error = math.atan2(sin, cos)
    nodes = character.scene.state.nodes
    rows = [character.node_row(n) for n in ("pelvis", "spine", "neck", "l_hip", "r_hip")]
    p = nodes.pos[rows[0]]
    dt = character.scene.dt
    left, right = character.node_row("l_hip"), character.node_row("r_hip")
    width = float(np.hypot(*(nodes.pos[left] - nodes.pos[right])[[0, 2]])) or 1.0
    spin = ((nodes.pos[right] - nodes.prev[right]) - (nodes.pos[left] - nodes.prev[left])) / dt
    omega = float(spin[0] * f[0] + spin[2] * f[2]) / width  # yaw rate, + turning left
    want = max(-TURN_RATE, min(TURN_RATE, TURN_GAIN * error / 10.0))
    # posture damps the turn of a standing pelvis: add that back, and servo the rate
    alpha = YAW_DAMP * want + TURN_GAIN * (want - omega)
    for i in rows:
        nodes.acc[i, 0] += alpha * (nodes.pos[i, 2] - p[2])
        nodes.acc[i, 2] -= alpha * (nodes.pos[i, 0] - p[0])
    return False


def step_back(character, memory: dict, facing: np.ndarray, stride: float, pace: float) -> None:
    """Walk backwards at ``pace``, called every step: once the last step is down and braced, the
    forward foot steps to ``stride`` behind the other, under its own hip, and the pelvis
    follows over the feet (posture's balance). The gait's own steps are held off meanwhile, as
    a kick holds them off: by the feet's step timers. ``memory``: the goal's, for the clock."""
    scene = character.scene
    nodes, ch, row = scene.state.nodes, scene.state.characters, character.character_row
    ch.swing[row] = np.maximum(ch.swing[row], 2.0 * scene.dt)  # no gait step meanwhile
    feet = [character.node_row(f) for f in FEET]
    if scene.time < memory.get("step_at", 0.0) or not all(nodes.flags[i] & NODE_LOCKED for i in feet):
        return
    ahead = [float(nodes.pos[i] @ facing) for i in feet]
    f = int(ahead[1] > ahead[0])  # the forward foot steps
    left = np.array([facing[2], 0.0, -facing[0]])  # the body's left, facing ``facing``
    half = 0.5 * float(np.linalg.norm(character.node("l_hip") - character.node("r_hip")))
    # a stride behind the other foot, under its own hip (a little wide: braced)
    other = nodes.pos[feet[1 - f]]
    side = float((character.position - other) @ left) + (1.2 * half if f == 0 else -1.2 * half)
    target = other - stride * facing + side * left
    target[1] = nodes.radius[feet[f]]
    # no further than the leg reaches from its hip, straight: a foot set down at full stretch
    # is a stretched leg, which the gait steps back under the hip at once (the stride lost)
    hip = character.node(("l_hip", "r_hip")[f])
    drop = float(hip[1] - target[1])
    reach = math.sqrt(max(0.0, (BACK_REACH * float(ch.leg_length[row])) ** 2 - drop * drop))
    out = (target - hip) * np.array([1.0, 0.0, 1.0])
    far = float(np.linalg.norm(out))
    if far > reach:
        target = hip + out * (reach / far)
        target[1] = nodes.radius[feet[f]]
    flight = BACK_STEP_TIME * math.sqrt(character.scale)
    launch_kick(character, FEET[f], target, flight)
    # (the next step as soon as this one's length calls for: one cut short by the leg's reach, sooner)
    stride = min(stride, max(0.0, float((other - target) @ facing)))
    memory["step_at"] = scene.time + max(flight + BACK_PAUSE, BACK_SHIFT * stride / pace)
