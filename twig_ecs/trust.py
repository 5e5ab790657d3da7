"""The trust model: which code a scene, a snapshot or a replay may make this process run.

Files from elsewhere are data unless the user says otherwise (``--trust``, or
:func:`trusting` in Python). Untrusted:

- a scene's plug-ins (``systems: - use: ...``) are modules of twig_ecs or of an installed
  plug-in package (the ``twig_ecs.behaviors`` entry points) - never a ``.py`` file, not
  even one beside the scene: a file is code the user has not vouched for;
- a snapshot is data (:mod:`twig_ecs.worlddata`); the plug-in modules it lists are used
  only when installed or already loaded here from a scene the user ran;
- replays write only their embedded YAML files, only inside their temporary folder.

Trusted (``--trust``): any file or module a scene names is imported.

Checking is not running: within :func:`checking_only` (``twig validate``) no plug-in code
runs at all, trusted or not; a plug-in file is read as text to see that it defines the
class named. See docs/reliability.md, "Trust".
"""

from __future__ import annotations

import contextlib
import contextvars
import sys
import threading
from collections.abc import Iterator
from importlib.metadata import entry_points
from pathlib import Path

from twig_ecs.errors import TwigError

_TRUSTED: contextvars.ContextVar[bool] = contextvars.ContextVar("twig_trusted", default=False)
#: Set while loading a scene that came inside a replay (data, not the user's own file).
_FROM_DATA: contextvars.ContextVar[bool] = contextvars.ContextVar("twig_from_data", default=False)
#: Set while only checking files (``twig validate``): no plug-in code runs, trusted or not.
_CHECKING: contextvars.ContextVar[bool] = contextvars.ContextVar("twig_checking", default=False)
HOW_TO_TRUST = "if you trust where it came from, run again with --trust"


class UntrustedCode(TwigError):
    """A file asked to run code that its trust level does not allow."""


def is_trusted() -> bool:
    """Does the user trust the files being loaded now (``--trust``)?"""
    return _TRUSTED.get()


def set_trusted(value: bool) -> None:
    """Trust (or not) every file this process loads from now on (the CLI's ``--trust``)."""
    _TRUSTED.set(bool(value))


@contextlib.contextmanager
def _setting(flag: contextvars.ContextVar[bool], value: bool) -> Iterator[None]:
    """Within the block, ``flag`` is ``value``; as before after it."""
    token = flag.set(value)
    try:
        yield
    finally:
        flag.reset(token)


def trusting(value: bool = True) -> contextlib.AbstractContextManager[None]:
    """Within the block, files are trusted (``value=True``) or not."""
    return _setting(_TRUSTED, bool(value))


def thread_trusting_as_now(target, *, name: str) -> threading.Thread:
    """A daemon thread that runs ``target`` trusting (and checking) as the caller does now.

    A new thread starts from a blank context: without this, the window's thread that loads
    the scene while the kernels compile refused ``twig play SCENE --trust``'s plug-in file
    ("run again with --trust") - on every first run with such a scene."""
    return threading.Thread(target=contextvars.copy_context().run, args=(target,), name=name, daemon=True)


def loading_data() -> contextlib.AbstractContextManager[None]:
    """Within the block, scenes being read came inside a data file (a replay): no plug-in files."""
    return _setting(_FROM_DATA, True)


def checking_only() -> contextlib.AbstractContextManager[None]:
    """Within the block, scenes are checked, not run: plug-in references are read, never imported."""
    return _setting(_CHECKING, True)


def is_checking_only() -> bool:
    """Are files being checked only (no plug-in code may run, see :func:`checking_only`)?"""
    return _CHECKING.get()


def installed_plugin_packages() -> set[str]:
    """Top-level package names of installed twig plug-ins (entry points of twig_ecs.behaviors)."""
    from twig_ecs.behavior import ENTRY_POINT_GROUP  # here: `twig --help` need not load behaviours

    return {ep.module.split(".")[0] for ep in entry_points(group=ENTRY_POINT_GROUP)}


def module_allowed(module: str) -> bool:
    """May an untrusted file make this process import ``module``?"""
    top = module.split(".")[0]
    return top == "twig_ecs" or top in installed_plugin_packages()


def check_plugin(reference: str, base_dir: str | Path | None) -> None:
    """Refuse (UntrustedCode, saying why and how) a ``use:`` reference the trust level forbids."""
    if is_trusted():
        return
    module, _, _ = reference.partition(":")
    if module.endswith(".py"):
        if _FROM_DATA.get():
            raise UntrustedCode(
                f"'{reference}': a scene inside a replay may not run plug-in files; {HOW_TO_TRUST}"
            )
        raise UntrustedCode(
            f"'{reference}' is a plug-in file: Python code, which a scene may run only when you trust it - "
            f"{HOW_TO_TRUST} (in Python: Scene.load(..., trust=True)), or install it as a package "
            "(entry point group twig_ecs.behaviors)"
        )
    if not module_allowed(module):
        raise UntrustedCode(
            f"'{reference}': '{module}' is neither part of twig_ecs nor an installed twig plug-in "
            f"(entry point group twig_ecs.behaviors); {HOW_TO_TRUST}"
        )


def check_snapshot_plugin(module: str, file: str | None) -> None:
    """Refuse a plug-in module a snapshot names unless trusted, installed or already loaded here."""
    if is_trusted() or module_allowed(module):
        return
    loaded = sys.modules.get(module)
    if module.startswith("twig_plugin_") and loaded is not None and file is not None:
        origin = getattr(loaded, "__file__", None)
        if origin is not None and Path(origin).resolve() == Path(file).resolve():
            return  # the scene the user ran loaded it from this very file
    where = f" (file {file})" if file else ""
    raise UntrustedCode(
        f"the snapshot asks to import plug-in module '{module}'{where}; snapshots are data and "
        f"import only twig_ecs and installed plug-ins - {HOW_TO_TRUST}"
    )
