"""A first run's second screen: the scene in slow motion while the kernels finish compiling.

The scene steps in a thread of its own (:class:`Stepper`), with each kernel as plain
Python until the workers have cached it. A plain-Python step of the schoolyard takes
0.2 s on a quiet machine and seconds on a busy one, so the window's thread never runs
one: each frame draws the scene when the stepper is between steps and otherwise draws
the last frame's shapes again with the progress brought up to date, so the window
redraws, and answers Esc, at its usual pace whatever a step costs. Other keys and the
mouse wait for the stepper to finish its step (a frame or two), then act as in the
:class:`~twig_ecs.graphics.play_view.PlayView` the window moves on to once the build
has ended.
"""

from __future__ import annotations

import threading
import time

from twig_ecs.graphics.loading import Loading, rest_after_frame
from twig_ecs.graphics.play_view import PlayView
from twig_ecs.graphics.view import View
from twig_ecs.trust import thread_trusting_as_now

#: The share of one core the slow-motion steps take (the stepper rests in between): the rest
#: is left to the compiling workers (resting only 30 ms a frame, the compile took 40% longer).
INTERIM_SHARE = 0.3


class Stepper:
    """Steps a viewer's scene one step at a time in a thread, holding :attr:`lock` while it does.

    Between steps it switches kernels the workers have cached to their compiled forms
    (:meth:`~twig_ecs.kernels.InterimKernels.update`). After :meth:`finish` it restores
    every kernel and takes one more step, so that loading them from the cache happens here
    and not in a frame of the window, and ends.
    """

    def __init__(self, viewer, kernels, share: float = INTERIM_SHARE) -> None:
        self.viewer, self.kernels, self.share = viewer, kernels, share
        self.lock = threading.Lock()
        self.steps = 0
        self.error: BaseException | None = None
        self._stop = threading.Event()
        self._finish = threading.Event()
        self._thread = thread_trusting_as_now(self._run, name="twig-slow-motion")

    def start(self) -> None:
        self._thread.start()

    def finish(self) -> None:
        """The build has ended: restore every kernel, step once with them, and stop."""
        self._finish.set()

    @property
    def ended(self) -> bool:
        """Has the thread ended (after :meth:`finish`, or on an error)?"""
        return not self._thread.is_alive()

    def stop(self) -> None:
        """Stop after the step under way (the window is closing) and wait for it."""
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join()

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                began = time.perf_counter()
                with self.lock:
                    finishing = self._finish.is_set()
                    if finishing:
                        self.kernels.finish()
                    else:
                        self.kernels.update()
                    if not self.viewer.paused:
                        self._step()
                if finishing:
                    return
                busy = time.perf_counter() - began
                self._stop.wait(max(0.02, busy * (1.0 - self.share) / self.share))
        except BaseException as exc:  # noqa: BLE001 - raised again on the window's thread
            self.error = exc

    def _step(self) -> None:
        viewer = self.viewer
        began = time.perf_counter()
        viewer.scene.step(1)
        viewer.note_own_steps(1, (time.perf_counter() - began) * 1000.0)
        self.steps += 1


class SlowMotionView(View):
    """The scene stepped by a :class:`Stepper` under the compile's progress; then the play view."""

    def __init__(self, loading: Loading, viewer) -> None:
        self.loading = loading
        self.play = PlayView(viewer)
        self.stepper = Stepper(viewer, loading.kernels)
        self._input: list[tuple[str, tuple]] = []  # events waiting for the stepper's step to end
        self._elapsed = 0.0
        self._drawn = (-1, 0.0)  # the stepper's step count and the time at the last full draw

    @property
    def viewer(self):
        return self.play.viewer

    def on_show_view(self) -> None:
        self.play.window = self.window
        self.play.on_show_view()
        self.viewer.alpha = 1.0  # no interpolation: a frame shows the last step
        self.viewer.keep_scene = True
        self.stepper.start()

    def on_hide_view(self) -> None:
        self.viewer.keep_scene = False

    def on_update(self, elapsed: float) -> None:
        window, stepper = self.window, self.stepper
        if stepper.error is not None:
            raise stepper.error
        if stepper.steps and window.first_step is None:
            window.first_step = time.perf_counter()
        if self.loading.build.poll():
            stepper.finish()
        if stepper.ended:
            self.viewer.notice = None
            self.viewer.frames = 0  # frames count from full speed, as after a plain wait
            window.full_speed = time.perf_counter()
            window.show_view(self.play)  # the time of the slow-motion frames is not simulated
            return
        self._elapsed += elapsed
        self.viewer.stats.add_frame(window.wall_gap * 1000.0)

    def on_draw(self) -> None:
        began = time.perf_counter()
        window, viewer = self.window, self.viewer
        size, scale = window.framebuffer()
        viewer.notice = self.loading.notice(scale)
        viewer.window_size = (window.width, window.height)
        if self._scene_changed() and self.stepper.lock.acquire(blocking=False):  # the scene is ours
            try:
                for name, args in self._input:
                    getattr(self.play, name)(*args)
                self._input.clear()
                if not window.closed:
                    viewer.move_camera(self._elapsed)
                    self._elapsed = 0.0
                    viewer.draw(window.renderer, size, scale)
                    self._drawn = (self.stepper.steps, began)
            finally:
                self.stepper.lock.release()
        else:  # a step is under way, or nothing moved: the last scene, the progress up to date
            viewer.redraw(window.renderer, size, scale)
        rest_after_frame(began)  # leave the cores to the compiling workers

    def _scene_changed(self) -> bool:
        """Does this frame show anything new: a step, input, a camera key held, or the camera's
        framing catching up (a full draw a second)? Otherwise the last scene is drawn again."""
        steps, when = self._drawn
        viewer = self.viewer
        return (self.stepper.steps != steps or bool(self._input) or bool(viewer.keys_down)
                or viewer.camera is None or time.perf_counter() - when >= 1.0)  # fmt: skip

    def on_close(self) -> None:
        self.loading.build.cancel()
        self.stepper.stop()  # after its step under way; the window is already off the screen
        self.loading.end_interim()
        self.play.on_close()

    # -- input: Esc at once, the rest once the step under way has ended ----------------------

    def on_key_press(self, symbol: int, modifiers: int) -> None:
        if symbol == self.window.keys.ESCAPE:
            self.window.close()
        else:
            self._input.append(("on_key_press", (symbol, modifiers)))

    def on_key_release(self, *args) -> None:
        self._input.append(("on_key_release", args))

    def on_mouse_press(self, *args) -> None:
        self._input.append(("on_mouse_press", args))

    def on_mouse_release(self, *args) -> None:
        self._input.append(("on_mouse_release", args))

    def on_mouse_drag(self, *args) -> None:
        self._input.append(("on_mouse_drag", args))

    def on_mouse_scroll(self, *args) -> None:
        self._input.append(("on_mouse_scroll", args))

    def on_mouse_motion(self, *args) -> None:
        self._input.append(("on_mouse_motion", args))
