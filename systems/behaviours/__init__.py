"""The built-in behaviours, one module each: its components, state, goal schema and system.

Every :class:`~twig_ecs.behavior.Behavior` defined in a module of this package is built in;
:func:`twig_ecs.plugins.builtin_behaviors` finds them, so a new behaviour is one module
(plus its test) and no list elsewhere changes.
"""
