"""The fixed-step clock: wall time in, whole simulation steps out.

The simulation always advances in steps of exactly ``dt`` (1/60 s); a clock turns the
wall time that passed into how many steps are due. The window (one call per drawn
frame), the server (one call per wake-up) and headless runs (seconds to steps) use
this one class, so pausing, single steps, slow motion and catching up after a stall
behave the same everywhere.
"""

from __future__ import annotations

import math

#: The simulation step (s): 60 Hz, as SPEC's Verlet and constraint constants assume.
STEP = 1.0 / 60.0
#: Fraction of a step that rounding may leave owed and that still counts as a whole step.
_ROUNDING = 1e-9


class FixedStepClock:
    """An accumulator of wall time that pays out fixed steps.

    ``max_steps``: the most steps one :meth:`advance` may pay out; time beyond that is
    dropped, so a stall (a slow frame, a breakpoint) cannot make the simulation spiral
    trying to catch up. ``max_elapsed`` (s, or None): a longer gap counts as this long.
    ``scale``: simulated seconds per wall second (0.5 is half speed). While ``paused``
    no time accumulates; :meth:`single_step` asks for one step all the same.
    """

    def __init__(self, dt: float = STEP, max_steps: int = 8, max_elapsed: float | None = 0.25,
                 scale: float = 1.0, paused: bool = False) -> None:  # fmt: skip
        if not dt > 0.0:
            raise ValueError(f"a clock's dt must be positive, got {dt}")
        if max_steps < 1:
            raise ValueError(f"a clock's max_steps must be at least 1, got {max_steps}")
        self.dt = dt
        self.max_steps = max_steps
        self.max_elapsed = max_elapsed
        self.scale = scale
        self.paused = paused
        self.accumulator = 0.0  # simulated seconds owed, less than one step after advance()
        self.dropped = 0.0  # simulated seconds given up to catch-up limits, in all
        #: wall seconds counted while running (after the ``max_elapsed`` cap), in all, and the
        #: simulated seconds they were worth at the scale of the moment: with ``paid`` steps,
        #: ``paid * dt + accumulator + dropped == simulated_wall`` (the slow-motion check)
        self.wall = 0.0
        self.simulated_wall = 0.0
        self.paid = 0  # steps paid out by advance(), in all (single steps included)
        self._single = 0

    @property
    def scale(self) -> float:
        """Simulated seconds per wall second (1 is real time)."""
        return self._scale

    @scale.setter
    def scale(self, value: float) -> None:
        if not (math.isfinite(value) and value >= 0.0):
            raise ValueError(f"a clock's time scale must be a finite number >= 0, got {value}")
        self._scale = float(value)

    def advance(self, elapsed: float) -> int:
        """Steps due after ``elapsed`` seconds of wall time (the caller runs them)."""
        if self.paused:
            self.accumulator = 0.0
            steps, self._single = self._single, 0
            self.paid += steps
            return steps
        if self.max_elapsed is not None:
            elapsed = min(elapsed, self.max_elapsed)
        elapsed = max(0.0, elapsed)
        self.wall += elapsed
        self.simulated_wall += elapsed * self._scale
        self.accumulator += elapsed * self._scale
        # a hair of tolerance: 0.25 s then 0.05 s of a 0.1 s clock are 3 steps, not 2 and a
        # remainder of 0.0999999... left by rounding
        steps = int(self.accumulator / self.dt + _ROUNDING)
        if steps > self.max_steps:
            self.dropped += self.accumulator - self.max_steps * self.dt
            steps = self.max_steps
            self.accumulator = steps * self.dt  # drop the time we cannot catch up with
        self.accumulator = max(0.0, self.accumulator - steps * self.dt)
        self.paid += steps
        return steps

    def single_step(self) -> None:
        """Pause, and have the next :meth:`advance` pay out exactly one step."""
        self.paused = True
        self._single += 1

    def due_now(self) -> None:
        """Make one step due at once (a server that starts or resumes steps without waiting)."""
        self.accumulator = max(self.accumulator, self.dt)

    def reset(self) -> None:
        """Forget the time owed (a new scene, or time spent loading that is not simulated)."""
        self.accumulator = 0.0
        self._single = 0

    @property
    def fraction(self) -> float:
        """How far (0..1) the wall clock is into the next step: for interpolating a drawing."""
        if self.paused:
            return 1.0
        return min(1.0, self.accumulator / self.dt)

    def until_next_step(self) -> float:
        """Wall seconds until the next step is due (inf when paused or stopped)."""
        if self.paused or self._scale == 0.0:
            return math.inf
        return max(0.0, self.dt - self.accumulator) / self._scale

    def steps_for(self, seconds: float) -> int:
        """Whole steps in ``seconds`` of simulated time (a headless run)."""
        return int(round(seconds / self.dt))
