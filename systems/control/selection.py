"""The compiled pass of behaviour selection (``select_behavior``'s kernel).

Every character's winner among the proposals made as lists, with the hysteresis of
:mod:`twig_ecs.systems.control.select_behavior` (whose per-character loop is the rule's
reference form), in one pass over a table of proposals: a row per character, a column per
proposal, idle's last.
"""

from __future__ import annotations

import numpy as np
from numba import njit

STICKINESS = 0.05  # activation bonus of the current winner
MIN_DWELL = 0.25  # s a winner keeps the floor against ordinary rivals
URGENT = 0.3  # a rival this much stronger takes over at once
IDLE = 0.1  # activation of doing nothing in particular


@njit(cache=True, nogil=True)
def choose_winners(values, codes, was, since, now, batch, best, alone, keys):
    """Every character's winner, as the per-character loop picks it.

    ``values`` (characters x proposals): activations, ``-inf`` where a character has no such
    proposal, the last column idle's (``IDLE`` for all); ``codes``: each column's behaviour
    code (no code twice); ``was``, ``since``: each character's winner code and the time it
    won; ``batch``: by code, whether that behaviour acts in a batch (or there is none to act).
    The highest proposal wins, the first column of equal ones (a dict's order, in which the
    behaviours proposed); the current winner, where it proposed, keeps the floor unless beaten
    by more than ``STICKINESS``, or by ``URGENT`` within ``MIN_DWELL`` of winning. Writes the
    winners' codes (``best``), whether each one needs the per-character loop (``alone``: it
    switched, or its winner acts per character) and the listed proposals it made as bits of
    their codes (``keys``).
    """
    n, width = values.shape
    for i in range(n):
        top = 0
        for j in range(1, width):
            if values[i, top] < values[i, j]:
                top = j
        winner = codes[top]
        if winner != was[i]:
            for j in range(width):
                if codes[j] == was[i] and values[i, j] != -np.inf:
                    # the loop's arithmetic: best - (was + STICKINESS), now - since
                    margin = values[i, top] - (values[i, j] + STICKINESS)
                    held = now - since[i] < MIN_DWELL
                    if margin <= 0.0 or (held and margin < URGENT):
                        winner = was[i]
                    break
        best[i] = winner
        alone[i] = winner != was[i] or not batch[winner]
        key = np.int64(0)
        for j in range(width - 1):
            if values[i, j] != -np.inf:
                key |= np.int64(1) << codes[j]
        keys[i] = key
