"""``twig bench``: median step times split by system, beside MuJoCo (docs/performance.md).

:mod:`~twig_ecs.bench.cases` builds the scenes, :mod:`~twig_ecs.bench.timing` times
them system by system, :mod:`~twig_ecs.bench.mujoco_ragdolls` steps MuJoCo's
ragdolls (optional ``bench`` extra), :mod:`~twig_ecs.bench.run` runs it all and
:mod:`~twig_ecs.bench.table` prints it.
"""
