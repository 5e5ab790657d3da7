"""A first run's compile, as the window sees it: the build, its progress panels, and the scene to make.

:class:`Loading` is shared by the two views of a first run
(:mod:`~twig_ecs.graphics.loading_view`, :mod:`~twig_ecs.graphics.slow_motion_view`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from PIL import Image

from twig_ecs.graphics.overlay import text_panel

#: While the kernels compile, a frame every this many seconds at most (5 a second): each one
#: drawn leaves the cores to the compiling workers until then. Drawing the scene costs tens of
#: ms under software GL: at 20 frames a second the window took half a core from the compile.
LOADING_FRAME_S = 0.2


def rest_after_frame(began: float) -> None:
    """Sleep out the rest of a loading frame that began at ``began`` (perf_counter), at least 20 ms."""
    time.sleep(max(0.02, LOADING_FRAME_S - (time.perf_counter() - began)))


@dataclass
class Loading:
    """A window's state while the kernels compile: the build, and how to make the viewer.

    With ``interim`` the viewer is made from the second frame on (in a thread) and its scene
    steps with the kernels' plain-Python forms (:class:`~twig_ecs.kernels.InterimKernels`),
    each switched to its compiled form once the workers have cached it; without, it is made
    once the build has finished.
    """

    build: object  # a twig_ecs.kernels.KernelBuild (or anything with poll/status/fraction/cancel)
    make_viewer: object  # () -> Viewer
    caption: str
    interim: bool = False
    #: the kernels' interim state once the scene is made early (a twig_ecs.kernels.InterimKernels)
    kernels: object = None

    def start_interim(self):
        """Point the kernels at plain Python and make the viewer: the scene runs before the build ends."""
        from twig_ecs.kernels import InterimKernels

        self.kernels = InterimKernels().start()
        try:
            return self.make_viewer()
        except BaseException:
            self.end_interim()
            raise

    def end_interim(self) -> None:
        """Every kernel compiled again (the build finished or was cancelled)."""
        if self.kernels is not None:
            self.kernels.finish()

    def notice(self, scale: float) -> Image.Image:
        """The progress panel drawn over a scene already running in slow motion."""
        return self._cached(
            "_notice", scale, "slow motion until the kernels are compiled (first run only)", None
        )

    def panel(self, scale: float) -> Image.Image:
        """The progress panel: what compiles, a bar, and why the wait (made again on a change)."""
        why = "first run only: later starts load the compiled kernels from the cache"
        return self._cached("_panel", scale, why, "twig play: getting ready")

    def _cached(self, slot: str, scale: float, why: str, title: str | None) -> Image.Image:
        status, fraction = self.build.status(), self.build.fraction
        key = (status, fraction, scale)
        cached = getattr(self, slot, None)
        if cached is None or cached[0] != key:
            filled = round(24 * fraction)
            lines = [status, f"[{'#' * filled}{'.' * (24 - filled)}] {100 * fraction:3.0f}%", why]
            cached = (key, text_panel(lines, scale, title=title) if title else text_panel(lines, scale))
            setattr(self, slot, cached)
        return cached[1]
