"""kick: swing a foot through a point on a ballistic arc (SPEC 3's ballistic move).

A kick is a rare event (a behaviour decides on one now and then), so it is plain Python
on one character: the kicking foot is unlocked and sent, like a step of
:mod:`twig_ecs.systems.control.gait`, on an arc under gravity to a point (play sends it on
three: backswing, swing through the ball, follow-through); the foot's step timer
(``swing`` in the character table) runs for the arc's duration, so the gait neither plants
that foot nor starts another step until it is over, and the foot locks again where it
lands. The ball moves only because the leg's capsules meet it on the way (the collide
system): a kick that misses leaves it where it was. The arc is marked ``NODE_KICK``: it
drives on through a loose ball it meets (the ball takes the whole contact correction)
instead of being stopped by it; the mark ends with the move.

The gait is not changed: the kick writes the same fields a step writes (``flags``,
``move_time``, ``move_gravity``, ``prev`` and ``swing``), so the two never both drive a
foot at once.
"""

from __future__ import annotations

import numpy as np

from twig_ecs.store import (
    MOVE_ARC,
    NODE_IN_CONTACT,
    NODE_KICK,
    NODE_LOCK_ON_CONTACT,
    NODE_LOCKED,
    NODE_MOVING,
)

FEET = ("l_foot", "r_foot")


def foot_busy(character) -> bool:
    """Is either foot of ``character`` in the air in a step or a kick right now?

    Its flight, not the gait's step timer: walking, that timer runs the whole step period,
    feet down included, so a walker lining up slowly would never be free to kick.
    """
    n = character.scene.state.nodes
    rows = [character.node_row(f) for f in FEET]
    return bool(any(n.move_time[i] > 0.0 and not n.flags[i] & NODE_LOCKED for i in rows))


def launch_kick(character, foot: str, target, duration: float) -> None:
    """Send ``foot`` ('l_foot' or 'r_foot') on a ballistic arc to ``target`` in ``duration`` s.

    The arc is the gait's step arc: v0 = (target - p) / T - g T / 2 lands on ``target``
    after T under gravity, so the foot rises and falls through its swing.
    """
    assert foot in FEET, foot
    scene = character.scene
    st = scene.state
    n = st.nodes
    i = character.node_row(foot)
    dt = scene.dt
    g = np.asarray(scene.settings.gravity, dtype=np.float64)
    p = n.pos[i].copy()
    v0 = (np.asarray(target, dtype=np.float64) - p) / duration - 0.5 * g * duration
    n.flags[i] &= ~np.uint32(NODE_LOCKED | NODE_IN_CONTACT)
    n.flags[i] |= np.uint32(NODE_LOCK_ON_CONTACT | NODE_MOVING | NODE_KICK)
    n.move_time[i] = duration
    n.move_gravity[i] = MOVE_ARC
    n.prev[i] = p - v0 * dt
    # the foot's step timer: the gait leaves it alone (and steps no other foot) meanwhile
    st.characters.swing[character.character_row, FEET.index(foot)] = duration
