"""Is the window's simulation keeping up with the wall clock?

The window's clock pays out at most a few steps per drawn frame (a slow frame drops
time rather than spiralling), so on a slow machine - software OpenGL, a big crowd - the
scene runs slower than the time scale asks, and nothing else would say so. A
:class:`PaceMeter` adds up, over the last few wall seconds, the simulated seconds each
frame advanced against the wall seconds it took; the status line shows the ratio when
it falls short of the time scale (``behind: x0.53 of real time``).
"""

from __future__ import annotations

from collections import deque

#: Wall seconds the real-time factor is measured over (a one-off stall shows this long).
SPAN = 2.0
#: Below this share of the time scale, the simulation counts as falling behind.
BEHIND_BELOW = 0.9


class PaceMeter:
    """Simulated seconds per wall second over the last :data:`SPAN` wall seconds."""

    def __init__(self, span: float = SPAN) -> None:
        self.span = span
        self._frames: deque[tuple[float, float]] = deque()  # (wall s, simulated s) per frame
        self._wall = 0.0
        self._simulated = 0.0

    def add(self, wall: float, simulated: float) -> None:
        """A frame that took ``wall`` seconds and advanced the scene ``simulated`` seconds."""
        if wall <= 0.0:
            return
        self._frames.append((wall, simulated))
        self._wall += wall
        self._simulated += simulated
        while len(self._frames) > 1 and self._wall - self._frames[0][0] >= self.span:
            old_wall, old_simulated = self._frames.popleft()
            self._wall -= old_wall
            self._simulated -= old_simulated

    def reset(self) -> None:
        """Forget what was measured (paused, reloaded: a new start)."""
        self._frames.clear()
        self._wall = self._simulated = 0.0

    @property
    def factor(self) -> float | None:
        """Simulated seconds per wall second lately; None until half a span was measured."""
        if self._wall < 0.5 * self.span:
            return None
        return self._simulated / self._wall

    def behind(self, scale: float) -> float | None:
        """The factor when it falls short of ``scale`` (the time scale asked), else None."""
        factor = self.factor
        if factor is None or factor >= BEHIND_BELOW * scale:
            return None
        return factor
