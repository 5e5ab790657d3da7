"""The server's safety net: a step that raises is undone, and keeping the net costs little.

Before a step the server keeps a *checkpoint*, a snapshot of the world, at most every
:data:`CHECKPOINT_EVERY` frames, and logs every command that may change the world from
then on, as the record a recording writes (:mod:`twig_ecs.server.commandlog`) plus the
state hash the command left. A failed step at frame F is undone by restoring the
checkpoint and applying the logged commands again, through the same method functions
at the frames they were applied at, with the steps between and after them up to F:
steps and commands are deterministic (as a recording's replay), so this is the world as
it was before the failed step. Each command applied again must leave the state hash it
left the first time, and the world brought on to F the hash the world had there (when
the server knows it); if not, the rollback is refused (and said so) rather than a
different world served.

A snapshot of 1000 humanoids takes about 150 ms against a 10 ms step: taken before the
first step after every command, as it once was, a client spawning a crowd kept the
world thread snapshotting most of the time. Now a new checkpoint is taken sooner than
every CHECKPOINT_EVERY frames only when the log could not replay a command faithfully
(a refused command whose parameters were too long to keep, as in a recording) or holds
:data:`MAX_LOGGED` commands (a rollback applies at most that many again).

The checkpoint stays in this process, in the safe snapshot format: it is restored
trusting the plug-ins the served scene already loaded. (A pickle of the scene takes a
fifth of the time, but a second format to keep exact and never let near a file is not
worth it once a checkpoint is rare: 4 snapshots, 0.4 s, while 1000 spawns come in.)
"""

from __future__ import annotations

import traceback
from collections.abc import Callable
from typing import Any

from twig_ecs.scene import Scene
from twig_ecs.server.commandlog import apply_records, command_record
from twig_ecs.trust import trusting

#: Frames between checkpoints (the steps since one are applied again on a rollback).
CHECKPOINT_EVERY = 120
#: Most commands logged since a checkpoint: one more and the next step takes a new one
#: (a rollback applies at most this many again, about as long as they took: 499 humanoid
#: spawns 0.7 s; and a pile of spawns costs one checkpoint per this many).
MAX_LOGGED = 500


class ReplayDiverged(Exception):
    """A logged command, applied again on the restored checkpoint, left another world."""


class Rollback:
    """A checkpoint of the world and the commands applied since: what undoing a failed step needs.

    ``log(text)`` reports what went wrong (a world that cannot be saved, a rollback that failed).
    """

    def __init__(self, log: Callable[[str], None]) -> None:
        self.log = log
        self.enabled = True
        self.clear()

    def clear(self) -> None:
        """Forget the checkpoint and the log (a new scene): the next step takes a checkpoint."""
        self.checkpoint: bytes | None = None
        self.frame = -1  # the checkpoint's frame
        self.commands: list[dict[str, Any]] = []  # records since the checkpoint, each with its state hash
        self.due = True  # a checkpoint before the next step, whatever its frame

    def keep(self, scene: Scene) -> None:
        """Before a step: save the world if a checkpoint is due (see the module docstring)."""
        if not self.enabled:
            return
        if not (self.due or scene.frame - self.frame >= CHECKPOINT_EVERY):
            return
        try:
            self.checkpoint = scene.snapshot()
        except Exception as exc:  # a world that cannot be saved still runs, without the safety net
            self.log(f"no rollback point (the world cannot be saved: {exc}); steps run without one")
            self.enabled = False
            self.clear()
            return
        self.frame = scene.frame
        self.commands.clear()
        self.due = False

    def note(
        self, frame: int, method: str, params: dict[str, Any], error: str | None, state_hash: str
    ) -> None:
        """A command that may have changed the world was applied at ``frame``, leaving ``state_hash``."""
        if not self.enabled or self.due:  # the next checkpoint holds it
            return
        record = command_record(frame, method, params, error)
        if record.get("params_cut") or len(self.commands) >= MAX_LOGGED:
            self.due = True  # not replayable (or the log is long): the next step saves the world instead
            return
        record["state_hash"] = state_hash
        self.commands.append(record)

    def restore(self, frame: int, headless: Callable[[Scene], Any], state_hash: str | None) -> Scene | None:
        """The world as it was at ``frame`` (before a failed step), or None if it cannot be had.

        ``headless(scene)`` gives a server without clients for the restored scene: the
        logged commands are applied to it as the server applied them (nobody is told of
        what they set off again); it must stop hearing the scene when done (``detach()``).
        ``state_hash``: the world's before the failed step, if known: the restored one must match.
        """
        if self.checkpoint is None or not self.frame <= frame:
            return None
        try:
            with trusting():  # our own snapshot: its plug-ins are already loaded
                scene = Scene.restore(self.checkpoint)
        except Exception:  # a bug: the failed step's world stays, and is said to
            self.log(f"rolling back failed:\n{traceback.format_exc()}")
            return None
        try:
            self._replay(scene, frame, headless, state_hash)
        except Exception:  # a divergence, or a bug: as above
            self.log(f"rolling back failed:\n{traceback.format_exc()}")
            scene.close()
            return None
        return scene

    def _replay(
        self, scene: Scene, frame: int, headless: Callable[[Scene], Any], state_hash: str | None
    ) -> None:
        """Bring the restored checkpoint on to ``frame``: the logged commands and the steps between."""
        server = headless(scene)
        try:
            apply_records(server, self.commands, _stepper(scene), _gone, _checker(scene))
        finally:
            server.detach()
        scene.step(frame - scene.frame)
        if state_hash is not None and scene.state_hash() != state_hash:
            raise ReplayDiverged(f"the restored world at frame {frame} is not the one that was there")


def _gone(method: str) -> ReplayDiverged:
    return ReplayDiverged(f"the logged method '{method}' is not one of the restored scene's")


def _stepper(scene: Scene) -> Callable[[int], None]:
    def step_to(frame: int) -> None:
        if frame > scene.frame:
            scene.step(frame - scene.frame)

    return step_to


def _checker(scene: Scene) -> Callable[[dict[str, Any], str | None], None]:
    def check(record: dict[str, Any], error: str | None) -> None:
        if (error is None) != (record["error"] is None) or scene.state_hash() != record["state_hash"]:
            raise ReplayDiverged(
                f"'{record['method']}' at frame {record['frame']} did not do again what it did "
                f"(error then: {record['error']!r}, now: {error!r})"
            )

    return check
