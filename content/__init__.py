"""Built-in content shipped with twig-ecs: body templates (bodies/) and scenes (scenes/)."""
