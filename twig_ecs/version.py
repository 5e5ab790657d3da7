"""The release number: written once, here (pyproject.toml and ``twig_ecs.__version__`` read it)."""

__version__ = "0.1.0"
