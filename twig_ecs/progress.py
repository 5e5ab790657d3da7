"""Progress of long commands on stderr: in place on a terminal, as lines in a log.

A run, a replay or a render that takes a while says how far it has come, whether its
stderr is a terminal (one line rewritten in place) or a file or pipe (a line now and then,
so a log or CI output shows the command is alive). stdout - where ``--report json`` goes -
never sees it, and a command done within :attr:`Progress.QUIET` seconds says nothing.
"""

from __future__ import annotations

import time
from typing import TextIO


class Progress:
    """Says on ``stream`` how far ``label`` has come: ``label: frame 600 of 1800 (33%, 10 s simulated)``.

    Nothing for its first :attr:`QUIET` seconds, then every :attr:`EVERY` seconds on a
    terminal, or every ten times that as separate lines when ``stream`` is not one.
    """

    QUIET = 2.0
    EVERY = 1.0

    def __init__(self, stream: TextIO, label: str) -> None:
        self.stream, self.label, self.clock = stream, label, time.monotonic
        self.started = self.last = self.clock()
        self.live = bool(getattr(stream, "isatty", lambda: False)())
        self.shown = False

    def __call__(self, frame: int, last: int) -> None:
        """Frame ``frame`` of ``last`` is done (60 frames a simulated second)."""
        now = self.clock()
        every = self.EVERY if self.live else 10 * self.EVERY
        if now - self.started < self.QUIET or now - self.last < every:
            return
        self.last = now
        share = 100 * frame / max(last, 1)
        text = f"{self.label}: frame {frame} of {last} ({share:.0f}%, {frame / 60:.0f} s simulated)"
        self.stream.write(f"\r{text}" if self.live else text + "\n")
        self.stream.flush()
        self.shown = True

    def done(self) -> None:
        """End the line a terminal's progress was written on."""
        if self.shown and self.live:
            self.stream.write("\n")
            self.stream.flush()
