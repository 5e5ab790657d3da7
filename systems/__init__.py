"""Systems, in three feature packages that show the layers.

- :mod:`~twig_ecs.systems.physics`: integrate, constrain, collide, sense - one call each
  per step into a numba kernel looping over the whole :class:`~twig_ecs.store.PhysicsState`;
- :mod:`~twig_ecs.systems.control`: attention, behaviour selection, patrol and the
  controllers (gait, gaze, posture, arms, respiration), one kernel call each over the
  table of characters;
- :mod:`~twig_ecs.systems.behaviours`: one module per built-in behaviour, found by
  :func:`twig_ecs.plugins.builtin_behaviors` (no list to edit).

A package imports only from its own layer and those below it (physics <- control <-
behaviours). Which systems a scene runs is up to its plugins (:mod:`twig_ecs.plugins`);
the order of their stages is :data:`twig_ecs.schedule.PIPELINE`.
"""

from twig_ecs.kernelcache import configure_cache

configure_cache()  # before any system module defines its kernels (numba binds the cache then)
