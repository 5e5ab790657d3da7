"""The window's event log: the last few goal results and pains, with their times.

The status line shows one message at a time, so a goal's result ("parent: hug done")
was gone after a few seconds, overwritten by the next event, and pain showed only in the
inspector. The log keeps the last :data:`KEEP` of them, each with the simulated time it
happened, for a small panel over the view. A character hurt again and again (a yank
held, a scuffle) is one line that counts the blows, not a line per blow.
"""

from __future__ import annotations

from dataclasses import dataclass

#: Lines the log keeps (and the panel shows).
KEEP = 5
#: Simulated seconds a line stays on screen after its event.
SHOWN_FOR = 30.0
#: Pains of one body closer together than this (simulated s) share a line.
MERGE_WITHIN = 2.0


@dataclass
class Entry:
    """One line of the log: when (simulated s), what, and how many events it stands for."""

    time: float
    text: str
    merge_key: tuple | None = None
    count: int = 1

    def line(self, width: int = 0) -> str:
        """The entry as the panel shows it: ``12.4 s  parent: hug done`` (the time right-aligned
        in ``width`` characters)."""
        times = f" (x{self.count})" if self.count > 1 else ""
        return f"{self.time:{width}.1f} s  {self.text}{times}"


class EventLog:
    """The last few events worth a line, newest last."""

    def __init__(self, keep: int = KEEP) -> None:
        self.keep = keep
        self.entries: list[Entry] = []

    def add(self, time: float, text: str, merge_key: tuple | None = None) -> None:
        """Log ``text`` at simulated ``time``; an entry of the same ``merge_key`` made within
        :data:`MERGE_WITHIN` s is updated (its time, text and count) instead."""
        for entry in reversed(self.entries):
            if merge_key is not None and entry.merge_key == merge_key and time - entry.time <= MERGE_WITHIN:
                entry.time, entry.text, entry.count = time, text, entry.count + 1
                self.entries.remove(entry)
                self.entries.append(entry)  # the newest again
                return
        self.entries.append(Entry(time, text, merge_key))
        del self.entries[: -self.keep]

    def clear(self) -> None:
        """Forget every entry (a reloaded scene starts its own log)."""
        self.entries.clear()

    def lines(self, now: float) -> list[str]:
        """The lines to show at simulated time ``now``: events of the last :data:`SHOWN_FOR` s."""
        shown = [e for e in self.entries if now - e.time <= SHOWN_FOR]
        width = max((len(f"{e.time:.1f}") for e in shown), default=0)  # the times in one column
        return [e.line(width) for e in shown]
