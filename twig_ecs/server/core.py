"""The asyncio server: client sessions, the command queue and the simulation's own loop.

One thread, one event loop. Sessions read request lines, check them and queue
commands; only the simulation task touches the scene: at 60 Hz (or when stepped,
while paused) it steps, then applies the queued commands in arrival order, so every
command lands between two steps. Answers and notifications are written without
waiting for the client: a session that stops reading is first not read from (at most
:data:`MAX_INFLIGHT` unanswered requests each) and, if its unsent output passes
:data:`MAX_UNSENT` bytes, disconnected - the simulation never waits for a client.
"""

from __future__ import annotations

import asyncio
import collections
import inspect
import sys
import time
import traceback
from collections.abc import Callable
from typing import Any

import esper

from twig_ecs.behavior import BehaviorChanged, GoalDone, GoalFailed
from twig_ecs.character import CharacterHandle
from twig_ecs.clock import FixedStepClock
from twig_ecs.components import Character
from twig_ecs.errors import TwigError
from twig_ecs.events import Contact, Pain
from twig_ecs.scene import Scene
from twig_ecs.server import protocol as rpc
from twig_ecs.server.ports import DEFAULT_PORT, DEFAULT_TWIG_PORT  # noqa: F401 - their old home
from twig_ecs.server.protocol import RPCError
from twig_ecs.server.session import Command, JsonSession, Session
from twig_ecs.server.twigline import TwigSession
from twig_ecs.trust import trusting

#: Frames between the checkpoints a failed step is rolled back from (and after every command).
CHECKPOINT_EVERY = 120
#: Seconds a client of a server with a token has to authenticate before it is disconnected.
AUTH_TIMEOUT = 30.0
#: Most simulation steps run to catch up after a stall (then the clock drops the rest).
MAX_CATCH_UP = 5
#: Longest the loop spends applying queued commands before stepping again (s).
COMMAND_BUDGET = 0.008
#: Queued methods that leave the world as it was (no new rollback checkpoint after them).
READ_ONLY = frozenset(
    {"status", "list_entities", "get_state", "subscribe", "unsubscribe", "pause", "resume", "step"}
)  # step: only steps, which the rollback replays


class Server:
    """Serve a scene: JSON-RPC (and optionally the Twig line protocol) over TCP.

    ``await server.start()`` binds the ports (``port=0`` picks a free one, see
    :attr:`port`) and starts the simulation loop; ``await server.stop()`` ends both
    and closes the scene (if ``own_scene``). ``window``: a play window to draw each frame.
    ``recorder``: a :class:`~twig_ecs.replay.Recorder` that logs every applied command.
    ``rollback``: save the world before every step so that a step that raises is undone
    (costs a snapshot per step; without it a failed step may leave the world half-advanced).
    """

    def __init__(
        self,
        scene,
        host: str = "127.0.0.1",
        port: int = DEFAULT_PORT,
        twig_port: int | None = None,
        token: str | None = None,
        paused: bool = False,
        autonomous: bool = True,
        window=None,
        own_scene: bool = True,
        log: Callable[[str], None] | None = None,
        recorder=None,
        rollback: bool = True,
    ) -> None:
        self.scene = scene
        self.host = host
        self.port = port
        self.twig_port = twig_port
        self.token = token
        #: the simulation's clock: 60 Hz of wall time, at most MAX_CATCH_UP steps to catch up
        self.clock = FixedStepClock(scene.dt, max_steps=MAX_CATCH_UP, max_elapsed=None, paused=paused)
        self.autonomous = autonomous
        self.window = window
        self.own_scene = own_scene
        self.rollback = rollback
        self.auth_timeout = AUTH_TIMEOUT
        self.log = log or (lambda text: print(f"twig serve: {text}", file=sys.stderr, flush=True))
        self.sessions: set[Session] = set()
        self.goal_owners: dict[int, Session] = {}
        self.steps_run = 0
        # one queue per client, served in turn (one command each): a client that sends
        # thousands of requests delays another's by at most one command per busy client
        self._queues: dict[Session, collections.deque[Command]] = collections.OrderedDict()
        self._pending: list[Any] = []  # scene events since the last flush
        self._grabs: dict[int, tuple[str, str | None, str]] = {}
        self._listeners: list[asyncio.base_events.Server] = []
        self._sim: asyncio.Task | None = None
        self._wakeup: asyncio.Event | None = None
        self._stopped: asyncio.Event | None = None
        self.recorder = None
        self._adopt(scene)
        self.recorder = recorder

    def _adopt(self, scene) -> None:
        """Serve ``scene``: hear its events, apply the autonomy mode, note its grabs."""
        if self.recorder is not None:  # the window reloaded the scene: the recording is of the old one
            self.recorder.close(
                self.scene.frame, self.scene.state_hash(), note="scene reloaded; not recorded"
            )
            self.recorder = None
        self.scene = scene
        self.goal_owners.clear()
        self._pending.clear()
        self._checkpoint = None  # a new scene (the window reloaded it): checkpoints of the old are void
        if not self.autonomous:
            for name in scene.entity_names:
                handle = scene.entity(name)
                if isinstance(handle, CharacterHandle):
                    handle.autonomous = False
        for kind in ("goal.done", "goal.failed", "behavior.changed", "pain", "contact"):
            scene.on(kind, self._pending.append)
        scene.step(0)  # compile the kernels and install the systems before clients come
        self._grabs = {}
        self._grabs = self._read_grabs()

    # -- lifetime ---------------------------------------------------------------------------

    async def start(self) -> None:
        """Bind the ports and start the simulation loop."""
        self._wakeup = asyncio.Event()
        self._stopped = asyncio.Event()
        listener = await asyncio.start_server(self._accept(JsonSession), self.host, self.port)
        self._listeners.append(listener)
        self.port = listener.sockets[0].getsockname()[1]
        if self.twig_port is not None:
            listener = await asyncio.start_server(self._accept(TwigSession), self.host, self.twig_port)
            self._listeners.append(listener)
            self.twig_port = listener.sockets[0].getsockname()[1]
        self._sim = asyncio.create_task(self._run(), name="twig-simulation")

    async def serve_forever(self) -> None:
        """Run until :meth:`request_stop` (or the window closes), then stop."""
        assert self._stopped is not None, "start() first"
        waiters = [asyncio.create_task(self._stopped.wait())]
        if self._sim is not None:
            waiters.append(self._sim)
        await asyncio.wait(waiters, return_when=asyncio.FIRST_COMPLETED)
        await self.stop()

    def request_stop(self) -> None:
        if self._stopped is not None:
            self._stopped.set()

    async def stop(self) -> None:
        """Close the ports and every session; stop the loop; close the scene."""
        for listener in self._listeners:
            listener.close()
        for session in list(self.sessions):
            session.abort()
        if self._sim is not None and not self._sim.done():
            self._sim.cancel()
            try:
                await self._sim
            except asyncio.CancelledError:
                pass
        for listener in self._listeners:
            await listener.wait_closed()
        self._listeners.clear()
        while self._queues:
            self._next_command().done(None, RPCError(rpc.NOT_NOW, "the server is shutting down"))
        if self.recorder is not None:
            self.recorder.close(self.scene.frame, self.scene.state_hash())
        if self.window is not None and not self.window.closed:
            self.window.close()  # closes its scene too
        elif self.own_scene:
            self.scene.close()

    def _accept(self, kind: type[Session]):
        async def serve(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            session = kind(self, reader, writer)
            self.sessions.add(session)
            try:
                await session.serve()
            finally:
                self.sessions.discard(session)
                for goal, owner in list(self.goal_owners.items()):
                    if owner is session:  # its goals go on; nobody is told of their end
                        del self.goal_owners[goal]

        return serve

    # -- commands ------------------------------------------------------------------------------

    def submit(self, command: Command) -> None:
        """Queue a command for the simulation loop."""
        queue = self._queues.get(command.session)
        if queue is None:
            queue = self._queues[command.session] = collections.deque()
        queue.append(command)
        if self._wakeup is not None:
            self._wakeup.set()

    def _next_command(self) -> Command:
        """The next command, taking clients in turn (round robin over their own queues)."""
        session, queue = next(iter(self._queues.items()))
        command = queue.popleft()
        if queue:
            self._queues.move_to_end(session)
        else:
            del self._queues[session]
        return command

    async def _apply(self, command: Command) -> None:
        frame = self.scene.frame
        try:
            result = command.method.fn(self, command.session, **command.params)
            if inspect.isawaitable(result):
                result = await result
        except RPCError as exc:
            error = exc
        except KeyError as exc:  # unknown entity names, with suggestions
            error = RPCError(rpc.INVALID_PARAMS, str(exc.args[0]) if exc.args else "unknown name")
        except TwigError as exc:
            error = RPCError(rpc.INVALID_PARAMS, str(exc))
        except Exception as exc:  # a bug: say so, keep serving
            self.log(f"{command.method.name} failed:\n{traceback.format_exc()}")
            error = RPCError(rpc.INTERNAL_ERROR, f"internal error in {command.method.name}: {exc!r}")
        else:
            error = None
        if command.method.name not in READ_ONLY:
            self._changed = True  # the next step saves a new rollback checkpoint first
        if self.recorder is not None:
            self.recorder.command(frame, command.method.name, command.params, error and error.message)
        self._flush()  # what the command set off (a cancelled goal), before its answer
        try:
            command.done(result if error is None else None, error)
        except Exception:  # answering one client must never stop the simulation for all
            self.log(f"answering {command.method.name} failed:\n{traceback.format_exc()}")
            command.session.abort()

    # -- the simulation ------------------------------------------------------------------------

    @property
    def paused(self) -> bool:
        """Is the simulation paused (it steps only when asked to)?"""
        return self.clock.paused

    @paused.setter
    def paused(self, value: bool) -> None:
        self.clock.paused = bool(value)

    def set_paused(self, paused: bool) -> None:
        """Pause or resume; a resumed simulation steps at once, then every 1/60 s."""
        self.paused = paused
        self._restart_clock(asyncio.get_running_loop().time())

    def _restart_clock(self, now: float) -> None:
        """The wall time from ``now`` on counts (not the time spent paused); a step is due now."""
        self._last_tick = self._next_draw = now
        self.clock.reset()
        self.clock.due_now()

    _last_tick = _next_draw = 0.0

    async def _run(self) -> None:
        """The simulation task: it never ends on an error, it logs it, pauses and goes on."""
        while True:
            try:
                await self._loop()
            except asyncio.CancelledError:
                raise
            except Exception:  # a bug outside the step itself: the server must keep answering
                self.log(f"the simulation loop failed; paused:\n{traceback.format_exc()}")
                self.paused = True
                await asyncio.sleep(0)

    async def _loop(self) -> None:
        loop = asyncio.get_running_loop()
        wakeup = self._wakeup
        assert wakeup is not None
        self._restart_clock(loop.time())
        clock = self.clock
        while True:
            now = loop.time()
            elapsed, self._last_tick = now - self._last_tick, now
            ticked = False
            if not self.paused:
                steps = clock.advance(elapsed)  # the time it cannot catch up with is dropped
                ticked = steps > 0
                for _ in range(steps):
                    if self.paused or not self._try_step():  # a command or a failed step paused it
                        break
            elif self.window is not None and now >= self._next_draw:
                ticked = True  # paused: the window still draws at 60 Hz
            if ticked and self.window is not None:
                self._next_draw = now + clock.dt
                self._draw()
            budget = time.perf_counter() + COMMAND_BUDGET
            while self._queues:
                await self._apply(self._next_command())
                if time.perf_counter() > budget:
                    break
            if self._queues:
                await asyncio.sleep(0)  # let the sockets in before the next batch
                continue
            wakeup.clear()
            if not self.paused:
                timer = loop.call_at(loop.time() + clock.until_next_step(), wakeup.set)
            elif self.window is not None:
                timer = loop.call_at(self._next_draw, wakeup.set)
            else:
                timer = None
            await wakeup.wait()
            if timer is not None:
                timer.cancel()

    def _try_step(self) -> bool:
        """One real-time step; False (and paused) if it failed."""
        try:
            self._step_frame()
        except RPCError:
            return False
        return True

    def _step_frame(self) -> None:
        """One step, or none at all: a step that raises is undone (see :meth:`_roll_back`)."""
        self._keep_checkpoint()
        try:
            self.scene.step(1)
        except Exception as exc:
            self.log(f"the simulation failed at frame {self.scene.frame}; paused:\n{traceback.format_exc()}")
            failed = self.scene.frame  # the frame the step started from
            rolled_back = self._roll_back(failed)
            self.paused = True
            self._pending.clear()
            cause = f"{type(exc).__name__}: {exc}"
            message = f"step {failed + 1} failed ({cause})" + (
                "; the world is as before it, paused" if rolled_back else "; paused"
            )
            for session in list(self.sessions):
                if session.authenticated:
                    session.send_event(
                        "simulation.error",
                        {"frame": self.scene.frame, "message": message, "rolled_back": rolled_back},
                    )
            raise RPCError(rpc.INTERNAL_ERROR, f"the simulation failed: {message}") from None
        self.steps_run += 1
        self._flush()

    # -- rollback: a checkpoint now and then, and the steps since replayed (they are deterministic) --

    _checkpoint: bytes | None = None
    _checkpoint_frame = -1
    _changed = True  # a command changed the world since the checkpoint

    def _keep_checkpoint(self) -> None:
        """Save the world every CHECKPOINT_EVERY frames and before the first step after a command."""
        if not self.rollback:
            return
        scene = self.scene
        due = self._checkpoint is None or scene.frame - self._checkpoint_frame >= CHECKPOINT_EVERY
        if not (due or self._changed):
            return
        try:
            self._checkpoint = scene.snapshot()
        except Exception as exc:  # a world that cannot be saved still runs, without the safety net
            self.log(f"no rollback point (the world cannot be saved: {exc}); steps run without one")
            self.rollback = False
            self._checkpoint = None
            return
        self._checkpoint_frame = scene.frame
        self._changed = False

    def _roll_back(self, frame: int) -> bool:
        """Put the world back as it was at ``frame`` (before the failed step); True if possible.

        The checkpoint is restored and stepped on to ``frame``: nothing but steps happened
        since it was taken, and steps are deterministic, so this is the world as it was.
        """
        checkpoint, since = self._checkpoint, self._checkpoint_frame
        if checkpoint is None or not since <= frame:
            return False
        try:
            with trusting():  # our own snapshot: its plug-ins are already loaded
                restored = Scene.restore(checkpoint)
            restored.step(frame - since)  # no server listening yet: these events were sent before
        except Exception:
            self.log(f"rolling back failed:\n{traceback.format_exc()}")
            return False
        old = self.scene
        self.scene = restored
        self._pending.clear()
        for kind in ("goal.done", "goal.failed", "behavior.changed", "pain", "contact"):
            restored.on(kind, self._pending.append)
        if self.window is not None:
            self.window.viewer.scene = restored
        old.close()
        restored.activate()
        return True

    async def step_frames(self, n: int) -> None:
        """Advance ``n`` frames (the ``step`` method), letting the sockets in now and then.

        Queued commands wait until all ``n`` are done: they land after the last one.
        """
        for k in range(n):
            self._step_frame()
            if k % 30 == 29:
                await asyncio.sleep(0)

    def _draw(self) -> None:
        window = self.window
        viewer = window.viewer
        viewer.paused = self.paused
        viewer.accumulator = 0.0  # the server steps the scene; the viewer only draws it
        window.frame(0.0)
        if window.closed:
            self.request_stop()
            return
        if viewer.scene is not self.scene:  # R reloaded the scene in the window
            self._adopt(viewer.scene)
        if viewer.paused != self.paused:  # Space in the window
            self.set_paused(viewer.paused)

    def remove_entity(self, name: str) -> None:
        """Remove an entity; the goals of or naming it fail first ("'x' was removed")."""
        scene = self.scene
        scene.activate()
        removed = scene._entity_id(name)
        for entity, _ in list(esper.get_component(Character)):
            handle = scene.character_handle(entity)
            for goal in handle.goals:
                if entity == removed or name in (goal.params.get(k) for k in ("target", "to", "on")):
                    scene.end_goal(handle, goal, False, f"'{name}' was removed")
        self._flush()  # while the name is still known: goal.failed names the character, not its id
        scene.remove(name)
        self._flush()

    # -- events -> notifications ------------------------------------------------------------------

    def _read_grabs(self) -> dict[int, tuple[str, str | None, str]]:
        scene = self.scene
        grabs = {}
        for entity, joint in scene.grabs():
            known = self._grabs.get(entity)
            if known is None:
                holder = scene.name_of(joint.holder) or str(joint.holder)
                character = esper.try_component(joint.holder, Character)
                hands = character.holding.items() if character else ()
                hand = next((h for h, g in hands if g == entity), None)
                known = (holder, hand, scene.name_of(joint.held) or str(joint.held))
            grabs[entity] = known
        return grabs

    def _flush(self) -> None:
        """Turn the scene's events since the last flush (and grab changes) into notifications."""
        grabs = self._read_grabs()
        events: list[tuple[str, Any]] = [(e.kind, e) for e in self._pending]
        self._pending.clear()
        for entity in self._grabs.keys() - grabs.keys():
            events.append(("release", self._grabs[entity]))
        for entity in grabs.keys() - self._grabs.keys():
            events.append(("grab", grabs[entity]))
        self._grabs = grabs
        if not events:
            return
        scene = self.scene
        stamp = {"frame": scene.frame, "time": scene.time}
        for kind, event in events:
            owner = None
            if kind in ("goal.done", "goal.failed"):
                owner = self.goal_owners.pop(event.goal, None)
            to = [s for s in self.sessions if kind in s.subscriptions or s is owner]
            if not to:
                continue
            params = {**self._describe(kind, event), **stamp}
            for session in to:
                session.send_event(kind, params)

    def _describe(self, kind: str, event: Any) -> dict[str, Any]:
        name = self.scene.name_of

        def called(entity: int) -> str:
            return name(entity) or str(entity)

        if isinstance(event, GoalDone | GoalFailed):
            out = {"character": called(event.character), "goal": event.goal, "behavior": event.behavior}
            if isinstance(event, GoalFailed):
                out["reason"] = event.reason
            return out
        if isinstance(event, BehaviorChanged):
            return {"character": called(event.character), "old": event.old, "new": event.new}
        if isinstance(event, Pain):
            return {
                "body": called(event.body),
                "source": called(event.source_body),
                "energy": event.energy,
                "level": event.level,
            }
        if isinstance(event, Contact):
            return {"body": called(event.body), "other": called(event.other_body), "energy": event.energy}
        holder, hand, held = event  # grab / release
        return {"character": holder, "hand": hand, "target": held}
