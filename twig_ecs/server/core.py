"""The asyncio server: client sessions, the command queue and the simulation's own loop.

Two threads. The event loop's thread reads request lines, checks them, queues
commands and writes answers; ``ping``, ``status``, ``auth`` and ``subscribe`` are
answered there at once. The world itself is touched only by the *world thread*, one
job at a time: the simulation task (on the event loop) hands it one step, or one queued
command, and waits for it, so every command still lands between two steps, in arrival
order, and the loop stays free to answer while a step or a pile of spawns takes long.
Answers and notifications are written without waiting for the client: a session that
stops reading is first not read from (at most :data:`MAX_INFLIGHT` unanswered requests
each) and, if its unsent output passes :data:`MAX_UNSENT` bytes, disconnected - the
simulation never waits for a client. Commands still queued when their client goes are
dropped, never applied.
"""

from __future__ import annotations

import asyncio
import collections
import concurrent.futures
import functools
import gc
import inspect
import sys
import time
import traceback
from collections.abc import Callable
from typing import Any

from twig_ecs.behavior import BehaviorChanged, GoalDone, GoalFailed
from twig_ecs.character import CharacterHandle
from twig_ecs.clock import FixedStepClock
from twig_ecs.components import Character
from twig_ecs.errors import TwigError
from twig_ecs.events import Contact, Pain
from twig_ecs.server import protocol as rpc
from twig_ecs.server.access import check_token
from twig_ecs.server.ports import DEFAULT_PORT, DEFAULT_TWIG_PORT  # noqa: F401 - their old home
from twig_ecs.server.protocol import RPCError
from twig_ecs.server.rollback import CHECKPOINT_EVERY, Rollback  # noqa: F401 - CHECKPOINT_EVERY: its old home
from twig_ecs.server.session import Command, JsonSession, Session
from twig_ecs.server.twigline import TwigSession

#: Seconds a client of a server with a token has to authenticate before it is disconnected.
AUTH_TIMEOUT = 30.0
#: Most simulation steps run to catch up after a stall (then the clock drops the rest).
MAX_CATCH_UP = 5
#: Least time the loop may spend applying queued commands before stepping again (s); when
#: the last step took longer, as long as it took (a pile of spawns goes in big chunks while
#: the world still gets at least half the time).
COMMAND_BUDGET = 0.008
#: Most wall time one world job of a ``step`` call runs frames for before the loop looks
#: in again (s): a stop, a SIGTERM or a window frame waits at most about this long.
STEP_SLICE = 0.010
#: Queued methods that leave the world as it was (the rollback's log leaves them out; ``step``
#: only steps, which a rollback does again).
READ_ONLY = frozenset(("status", "list_entities", "get_state", "goal_schemas", "subscribe", "unsubscribe",
                       "pause", "resume", "step"))  # fmt: skip
#: The scene's event kinds the server turns into notifications.
HEARD = ("goal.done", "goal.failed", "behavior.changed", "pain", "contact")


class Server:
    """Serve a scene: JSON-RPC (and optionally the Twig line protocol) over TCP.

    ``await server.start()`` binds the ports (``port=0`` picks a free one, see
    :attr:`port`) and starts the simulation loop; ``await server.stop()`` ends both
    and closes the scene (if ``own_scene``). ``window``: a play window to draw each frame.
    ``recorder``: a :class:`~twig_ecs.replay.Recorder` that logs every applied command.
    ``rollback``: keep a checkpoint now and then and the commands applied since, so that
    a step that raises is undone (:mod:`twig_ecs.server.rollback`; without it a failed
    step may leave the world half-advanced).
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
        check_token(token)
        self.token = token
        #: the simulation's clock: 60 Hz of wall time, at most MAX_CATCH_UP steps to catch up
        self.clock = FixedStepClock(scene.dt, max_steps=MAX_CATCH_UP, max_elapsed=None, paused=paused)
        self.autonomous = autonomous
        self.window = window
        self.own_scene = own_scene
        self.auth_timeout = AUTH_TIMEOUT
        self.log = log or (lambda text: print(f"twig serve: {text}", file=sys.stderr, flush=True))
        self._rollback = Rollback(self.log)
        self._rollback.enabled = rollback
        self.sessions: set[Session] = set()
        self.goal_owners: dict[int, Session] = {}
        self.steps_run = 0
        #: wall seconds of the last real-time frame (checkpoint, step, events) on the world thread
        self.frame_cost = 0.0
        #: what ``status`` reports of the world, as of the end of the last world job
        self.world_status: dict[str, Any] = {}
        # one queue per client, served in turn (one command each): a client that sends
        # thousands of requests delays another's by at most one command per busy client
        self._queues: dict[Session, collections.deque[Command]] = collections.OrderedDict()
        self._pending: list[Any] = []  # scene events since the last flush
        self._outbox: list[tuple[Session, str, dict[str, Any]]] = []  # notifications to write
        self._world: concurrent.futures.ThreadPoolExecutor | None = None  # the world thread
        self._job: concurrent.futures.Future | None = None  # its current (or last) job
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
        self._rollback.clear()  # a new scene (the window reloaded it): the old one's checkpoint is void
        if not self.autonomous:
            for name in scene.entity_names:
                handle = scene.entity(name)
                if isinstance(handle, CharacterHandle):
                    handle.autonomous = False
        self._hear(scene)
        scene.step(0)  # compile the kernels and install the systems before clients come
        self._grabs = {}
        self._grabs = self._read_grabs()
        self._note_status()

    def _hear(self, scene) -> None:
        """Turn ``scene``'s events into notifications from now on (see :meth:`_flush`)."""
        for kind in HEARD:
            scene.on(kind, self._pending.append)

    def detach(self) -> None:
        """Stop hearing the scene's events (a server without clients done with a scene it lent)."""
        handlers = self.scene.bus.handlers
        for kind in HEARD:
            handlers[kind] = [h for h in handlers.get(kind, []) if h != self._pending.append]

    @property
    def rollback(self) -> bool:
        """Is a step that raises undone? (False once the world could not be saved.)"""
        return self._rollback.enabled

    # -- lifetime ---------------------------------------------------------------------------

    async def start(self) -> None:
        """Bind the ports and start the simulation loop."""
        # Everything alive now (numba's and the scene's objects, tens of thousands) is kept
        # out of the cyclic collector's full passes: one of those holds the interpreter for
        # 20 ms on a quiet machine and several times that on a busy one or in a big process,
        # and a ping or status waits behind it (issue 33). Reference counting still frees them.
        gc.freeze()
        self._wakeup = asyncio.Event()
        self._stopped = asyncio.Event()
        self._world = concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix="twig-world")
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
        await self._world_idle()  # the job under way (one frame or one command) ends first
        if self._world is not None:
            self._world.shutdown(wait=False)
            self._world = None
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
        gc.unfreeze()  # what this process kept is collectable again

    def _accept(self, kind: type[Session]):
        async def serve(reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
            session = kind(self, reader, writer)
            self.sessions.add(session)
            try:
                await session.serve()
            finally:
                self.sessions.discard(session)
                self.forget(session)
                for goal, owner in list(self.goal_owners.items()):
                    if owner is session:  # its goals go on; nobody is told of their end
                        self.goal_owners.pop(goal, None)

        return serve

    def forget(self, session: Session) -> None:
        """Drop what a gone client still has queued: nobody waits for it, it is never applied."""
        dropped = self._queues.pop(session, None)
        if dropped:
            self.log(f"client {session.peer} left; {len(dropped)} queued command(s) dropped")

    # -- the world thread ----------------------------------------------------------------------

    async def in_world(self, fn: Callable[[], Any]) -> Any:
        """Run ``fn()`` on the world thread (the only one that touches the scene) and wait for it.

        Jobs never overlap: only the simulation task calls this, one job at a time. The
        notifications the job set off are written when it ends (before its caller answers).
        Before :meth:`start` (a replay, a test) it simply runs here.
        """
        if self._world is None:
            return self._job_body(fn)
        job = self._job = self._world.submit(self._job_body, fn)
        try:
            return await asyncio.wrap_future(job)
        finally:
            if job.done():  # not when the caller was cancelled mid-job: stop() waits for it
                self._deliver()

    def _job_body(self, fn: Callable[[], Any]) -> Any:
        try:
            return fn()
        finally:  # what it set off (a cancelled goal) is sent before its answer
            self._flush()
            self._note_status()

    async def _world_idle(self) -> None:
        """Wait until the world thread has finished its job, if it has one."""
        job = self._job
        if job is not None and not job.done():
            try:
                await asyncio.wrap_future(job)
            except BaseException:  # noqa: BLE001 - its own caller reported what went wrong
                pass

    def _note_status(self) -> None:
        """Keep what ``status`` says of the world (read while the world thread works)."""
        scene = self.scene
        self.world_status = {"scene": scene.name, "frame": scene.frame, "time": scene.time,
                             "state_hash": scene.state_hash()}  # fmt: skip

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
        if command.session.gone:  # its client left (or was dropped) after queueing it
            self.forget(command.session)
            return
        before = self.world_status  # the world as this command finds it
        frame = self.scene.frame
        fn = command.method.fn
        try:
            if inspect.iscoroutinefunction(fn):  # step: hands its frames to the world thread itself
                result = await fn(self, command.session, **command.params)
            else:
                result = await self.in_world(functools.partial(fn, self, command.session, **command.params))
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
        if command.method.name not in READ_ONLY:  # logged: a rollback applies it again
            message, after = None if error is None else error.message, self.world_status["state_hash"]
            self._rollback.note(frame, command.method.name, command.params, message, after)
        if self.recorder is not None:
            self._record(before, frame, command, error)
        self._deliver()  # what the command set off (a cancelled goal), before its answer
        try:
            command.done(result if error is None else None, error)
        except Exception:  # answering one client must never stop the simulation for all
            self.log(f"answering {command.method.name} failed:\n{traceback.format_exc()}")
            command.session.abort()

    def _record(self, before: dict[str, Any], frame: int, command: Command, error: RPCError | None) -> None:
        """Log an applied command; at the recording's size limit, end it as the world was before it."""
        recorder = self.recorder
        assert recorder is not None
        if recorder.command(frame, command.method.name, command.params, error and error.message):
            return
        self._stop_recording(recorder.full_note, before["frame"], before["state_hash"])

    def _stop_recording(self, note: str, frame: int | None = None, state_hash: str | None = None) -> None:
        """End the recording with ``note`` at ``frame`` (now, unless given); serve on unrecorded."""
        recorder = self.recorder
        assert recorder is not None
        frame = self.scene.frame if frame is None else frame
        recorder.close(frame, self.scene.state_hash() if state_hash is None else state_hash, note=note)
        self.recorder = None
        self.log(f"{note} at frame {frame} ({recorder.path}); serving on unrecorded")

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
        self._restart_clock(time.monotonic())  # the event loop's clock (runs on the world thread too)

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
        self._restart_clock(time.monotonic())
        clock = self.clock
        while True:
            now = time.monotonic()
            elapsed, self._last_tick = now - self._last_tick, now
            ticked = False
            if not self.paused:
                steps = clock.advance(elapsed)  # the time it cannot catch up with is dropped
                ticked = steps > 0
                for _ in range(steps):
                    if self.paused or not await self._try_step():  # a command or a failed step paused it
                        break
            elif self.window is not None and now >= self._next_draw:
                ticked = True  # paused: the window still draws at 60 Hz
            if ticked and self.window is not None:
                self._next_draw = now + clock.dt
                self._draw()
            # commands in a chunk as long as the last frame took (at least COMMAND_BUDGET):
            # a pile of them goes in a few frames, and the world still gets half the time
            budget = time.perf_counter() + max(COMMAND_BUDGET, self.frame_cost)
            while self._queues:
                await self._apply(self._next_command())
                if time.perf_counter() > budget:
                    break
            if self._queues:
                await asyncio.sleep(0)  # let the sockets in before the next chunk
                continue
            wakeup.clear()
            if not self.paused:
                timer = loop.call_later(clock.until_next_step(), wakeup.set)
            elif self.window is not None:
                timer = loop.call_later(max(0.0, self._next_draw - time.monotonic()), wakeup.set)
            else:
                timer = None
            await wakeup.wait()
            if timer is not None:
                timer.cancel()

    async def _try_step(self) -> bool:
        """One real-time step on the world thread; False (and paused) if it failed."""
        started = time.perf_counter()
        try:
            await self.in_world(self._step_frame)
        except RPCError:
            return False
        finally:
            self.frame_cost = time.perf_counter() - started
        return True

    def _step_frame(self) -> None:
        """One step, or none at all: a step that raises is undone (see :meth:`_roll_back`)."""
        self._rollback.keep(self.scene)
        try:
            self.scene.step(1)
            if self.recorder is not None and self.recorder.past_frames(self.scene.frame):
                self._stop_recording(self.recorder.frames_note)
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
            params = {"frame": self.scene.frame, "message": message, "rolled_back": rolled_back}
            self._outbox += [(s, "simulation.error", params) for s in tuple(self.sessions) if s.authenticated]
            raise RPCError(rpc.INTERNAL_ERROR, f"the simulation failed: {message}") from None
        self.steps_run += 1
        self._flush()

    # -- rollback: a checkpoint now and then, the commands since, all applied again (see rollback.py) --

    def _roll_back(self, frame: int) -> bool:
        """Put the world back as it was at ``frame`` (before the failed step); True if possible."""
        known = self.world_status  # as the last world job left it: the failed step's own job began there
        state_hash = known["state_hash"] if known["frame"] == frame else None  # else a `step` call's slice
        restored = self._rollback.restore(frame, self._headless, state_hash)
        if restored is None:
            return False
        old = self.scene
        self.scene = restored
        self._pending.clear()
        self._hear(restored)
        if self.window is not None:
            self.window.viewer.scene = restored
        old.close()
        return True

    def _headless(self, scene) -> Server:
        """A server without clients for ``scene``: logged commands are applied to it as this one did."""
        server = Server(scene, own_scene=False, log=self.log, rollback=False)  # autonomous: leaves them be
        server.autonomous = self.autonomous  # and spawns as this server does
        return server

    async def step_frames(self, n: int) -> None:
        """Advance ``n`` frames (the ``step`` method) on the world thread, a slice at a time.

        Queued commands wait until all ``n`` are done: they land after the last one.
        Between slices (about :data:`STEP_SLICE` s each) the loop may stop the server.
        """
        left = n
        while left > 0:
            left -= await self.in_world(functools.partial(self._step_slice, left))

    def _step_slice(self, most: int) -> int:
        """Frames, at most ``most``, for about STEP_SLICE s (at least one); returns how many."""
        until = time.perf_counter() + STEP_SLICE
        done = 0
        while done < most:
            self._step_frame()
            done += 1
            if time.perf_counter() > until:
                break
        return done

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
        removed = scene.entity_id(name)
        for entity, _ in list(self.scene.world.get_component(Character)):
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
                character = self.scene.world.try_component(joint.holder, Character)
                hands = character.holding.items() if character else ()
                hand = next((h for h, g in hands if g == entity), None)
                known = (holder, hand, scene.name_of(joint.held) or str(joint.held))
            grabs[entity] = known
        return grabs

    def _flush(self) -> None:
        """Turn the scene's events since the last flush (and grab changes) into notifications.

        Runs on the world thread: they are stamped with the frame now and queued for
        :meth:`_deliver`, which writes them from the event loop's thread.
        """
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
        sessions = tuple(self.sessions)  # one copy: the event loop's thread adds and drops them
        for kind, event in events:
            owner = None
            if kind in ("goal.done", "goal.failed"):
                owner = self.goal_owners.pop(event.goal, None)
            to = [s for s in sessions if kind in s.subscriptions or s is owner]
            if not to:
                continue
            params = {**self._describe(kind, event), **stamp}
            self._outbox += [(session, kind, params) for session in to]

    def _deliver(self) -> None:
        """Write the notifications the world thread queued (on the event loop's thread)."""
        out, self._outbox = self._outbox, []
        for session, kind, params in out:
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
