"""Record a served session and replay it headless: now :mod:`twig_ecs.server.replay`.

This module keeps the old import path (``twig_ecs.replay.replay(path)``) working.
"""

from twig_ecs.server.replay import (
    CLOCK_METHODS,
    FORMAT_VERSION,
    MAX_EMBEDDED_BYTES,
    MAX_FRAMES,
    MAX_REPLAY_BYTES,
    MAX_SEED,
    HeadlessSession,
    Recorder,
    ReplayError,
    read_replay,
    replay,
    scene_files,
)

__all__ = ["CLOCK_METHODS", "FORMAT_VERSION", "MAX_EMBEDDED_BYTES", "MAX_FRAMES", "MAX_REPLAY_BYTES",
           "MAX_SEED", "HeadlessSession", "Recorder", "ReplayError", "read_replay", "replay",
           "scene_files"]  # fmt: skip
