"""Shared fixtures: scenes that are always closed, so no test sees another's world."""

from __future__ import annotations

import esper
import numpy as np
import pytest

from twig_ecs import Scene, Settings


@pytest.fixture
def scenes():
    """A list to put scenes in; every scene in it is closed after the test."""
    made: list[Scene] = []
    yield made
    for scene in made:
        scene.close()
    leftover = [w for w in esper.list_worlds() if w.startswith("twig-scene")]
    assert not leftover, f"scenes left open: {leftover}"


@pytest.fixture
def empty_scene(scenes):
    """An empty scene with default settings (gravity on, ground plane)."""
    scene = Scene.load("empty")
    scenes.append(scene)
    return scene


@pytest.fixture
def zero_g_scene(scenes):
    """An empty scene without gravity."""
    scene = Scene(settings=Settings(gravity=np.zeros(3)))
    scenes.append(scene)
    return scene
