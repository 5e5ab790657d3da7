"""The ``twig`` command line: validate, run, and (from twig_ecs.graphics) play and render."""

from __future__ import annotations

import argparse
import functools
import importlib
import json
import sys
from collections.abc import Sequence

from twig_ecs.argtypes import positive_seconds, seconds_number, seed_number  # noqa: F401 - seconds_number: old home
from twig_ecs.errors import TwigError
from twig_ecs.progress import Progress
from twig_ecs.trust import checking_only, is_trusted, trusting


def _add_scene_args(
    p: argparse.ArgumentParser, scene_default: str | None = None, scene_optional: bool = False
) -> None:
    """The arguments every scene-running command shares: SCENE, --seed, --content."""
    if scene_optional:
        p.add_argument("scene", nargs="?", default=None, help=_scene_help())
    elif scene_default is None:
        p.add_argument("scene", help=_scene_help())
    else:
        p.add_argument("scene", nargs="?", default=scene_default, help=_scene_help(scene_default))
    p.add_argument("--seed", type=seed_number, default=0, help="random seed, 0 or more (default 0)")
    p.add_argument("--content", action="append", default=[], metavar="DIR",
                   help="extra folder of body templates and scenes (repeatable)")  # fmt: skip
    p.add_argument("--count", type=str, default=None, metavar="N",
                   help="the scene's 'count' parameter (e.g. characters in the crowd)")  # fmt: skip
    p.add_argument("--param", "--set", dest="param", action="append", default=[], metavar="NAME=VALUE",
                   type=_param, help="set a parameter the scene declares, or any value by a dotted path: "
                   "attachment.safe_distance=3 (a behaviour's), ball.damping.ground=0.01 (an entity's), "
                   "settings.iterations=10 (repeatable)")  # fmt: skip
    p.add_argument("--trust", action="store_true",
                   help="let scenes, snapshots, replays run plug-in code (docs/reliability.md)")  # fmt: skip
    p.set_defaults(scene_parameters=True)


def _param(text: str) -> tuple[str, str]:
    name, sep, value = text.partition("=")
    if not sep or not name.strip():
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got '{text}'")
    return name.strip(), value.strip()


def scene_parameters(args: argparse.Namespace) -> dict[str, str]:
    """The scene parameters given on the command line (``--param k=v``, ``--count N``)."""
    out = dict(getattr(args, "param", []) or [])
    if getattr(args, "count", None) is not None:
        out["count"] = args.count
    return out


def builtin_scenes() -> list[str]:
    """Names of the scenes shipped with twig-ecs."""
    from twig_ecs.library import builtin_dir

    return sorted(p.stem for p in (builtin_dir() / "scenes").glob("*.yaml"))


def _scene_help(default: str | None = None) -> str:
    known = ", ".join(builtin_scenes())
    tail = f"; default: {default}" if default else ""
    return f"a scene .yaml file or a built-in name ({known}{tail})"


def cmd_validate(args: argparse.Namespace) -> int:
    """Check scene and template files; print one line per file."""
    from twig_ecs.library import ContentLibrary, read_document
    from twig_ecs.scenefile import check_span, read_scene

    failures = 0
    try:
        library = ContentLibrary(args.content)
    except TwigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    for name in args.files:
        try:
            path = library.scene_path(name)
            doc = read_document(path)
            if "template" in doc:
                lib = library.copy()
                tname = str(doc["template"])
                lib.add_template(tname, doc)
                template = lib.template(tname)  # as spawned at its default height, too:
                check_span(template, None, doc, "defaults" if "defaults" in doc else "nodes", "")
                print(f"ok: {path} (body template '{tname}')")
            else:
                with checking_only():  # validating runs no plug-in code, trusted or not
                    plan = read_scene(path, library)
                plugins = [str(spec.where[0].get("use")) for spec in plan.systems if spec.cls is None]
                trust = "" if is_trusted() else " - it runs only with --trust"
                note = f"; plug-in code not run: {', '.join(plugins)}{trust}" if plugins else ""
                print(f"ok: {path} (scene '{plan.name}', {len(plan.entities)} entities{note})")
        except TwigError as exc:
            failures += 1
            for line in str(exc).splitlines():  # every mistake in the file, one a line
                print(f"error: {line}", file=sys.stderr)
    return 1 if failures else 0


def cmd_run(args: argparse.Namespace) -> int:
    """Run a scene headless for some seconds; optionally soak-check it, save or load a snapshot, replay."""
    from twig_ecs.report import run_with_report

    if args.replay:
        return _replay(args)
    if (args.scene is None) == (args.load is None):
        raise TwigError("give a SCENE to run, or --load a snapshot (not both)")
    limits = _soak_limits(args)
    scene = None
    if args.load:
        from twig_ecs.snapshot import load

        scene = load(args.load)
    report = run_with_report(args.scene, args.seconds, seed=args.seed, content=args.content,
                             progress=True, trace=args.trace,
                             plot=args.plot, parameters=args.parameters, limits=limits, scene=scene,
                             save=args.save)  # fmt: skip
    if args.report == "json":
        print(json.dumps(report, indent=2))
    else:
        print(f"{report['scene']}: {report['frames']} frames ({report['seconds']:.2f} s simulated), "
              f"median step {report['step_ms']['median']:.3f} ms, "
              f"max link error {report['max_link_error'] * 100:.2f}%, "
              f"max penetration {report['max_penetration_m'] * 100:.2f} cm, "
              f"nan: {str(report['nan']).lower()}, state {report['state_hash']}")  # fmt: skip
        if limits is not None:
            min_y = report["min_node_y"]
            print(f"soak: max speed {report['max_speed_m_s']:.2f} m/s, "
                  f"min node y {'-' if min_y is None else f'{min_y:.4f}'} m, "
                  f"max penetration {report['max_penetration_m']:.4f} m, "
                  f"max link error {report['max_link_error']:.3f}, "
                  f"max kinetic energy {report['max_kinetic_energy_j']:.1f} J")  # fmt: skip
        if args.save:
            print(f"saved snapshot at t={report['seconds']:.2f} s to {args.save}")
    if limits is not None and report["violation"]:
        print(f"soak failed: {report['violation']['message']}", file=sys.stderr)
        return 1
    return 1 if report["nan"] else 0


def cmd_sweep(args: argparse.Namespace) -> int:
    """Run the product of seeds and values, print a summary, write the table."""
    from twig_ecs import sweep

    seeds = sweep.parse_seeds(args.seeds)
    grid = dict(sweep.parse_values(text) for text in args.sweep)
    runs = sweep.plan_runs(seeds, grid)
    if args.workers is not None and args.workers < 1:
        raise TwigError("--workers: give 1 or more")
    sweep.check_names(args.scene, list(grid), args.content)
    progress = sweep.SweepProgress(len(runs))
    if args.cluster:
        rows = sweep.run_cluster(args.cluster, args.scene, args.seconds, runs, args.content, progress)
    else:
        rows = sweep.run_local(args.scene, args.seconds, runs, args.content, args.workers, progress)
    path = sweep.write_table(rows, args.output, list(grid), args.metric)
    if args.plot:
        from twig_ecs.sweepplot import plot_chance

        if not grid or not args.metric:
            raise TwigError("--plot draws the first --metric against the first --set: give both")
        print(f"plot: {plot_chance(rows, next(iter(grid)), args.metric[0], args.plot)}")
    for line in sweep.summary(rows, list(grid), args.metric):
        print(line)
    stopped = len(rows) < len(runs)
    print(
        f"{len(rows)} of {len(runs)} runs in {path}"
        + (" (stopped: the finished runs are kept)" if stopped else "")
    )
    return 130 if stopped else 0


def _list(kind, choices=None):
    def parse(text: str):
        items = [kind(x) for x in text.split(",") if x.strip()]
        if choices is not None and not set(items) <= set(choices):
            raise argparse.ArgumentTypeError(f"choose from {', '.join(choices)}")
        return tuple(items)

    return parse


def cmd_bench(args: argparse.Namespace) -> int:
    """Time the schoolyard, crowds and ragdoll piles (and MuJoCo's ragdolls beside them)."""
    from twig_ecs.bench.run import progress_printer, run_bench
    from twig_ecs.bench.table import format_report

    say = progress_printer()
    report = run_bench(args.cases, args.sizes, args.steps, args.warmup, mujoco=not args.no_mujoco, say=say)
    if sys.stderr.isatty():
        sys.stderr.write("\r\033[K")
    print(json.dumps(report, indent=2) if args.json else format_report(report))
    return 1 if any(r["nan"] for r in report["cases"]) else 0


def _soak_limits(args: argparse.Namespace):
    """SoakLimits from --soak and the limit flags (any limit flag implies --soak), or None."""
    from dataclasses import replace

    from twig_ecs.soak import SoakLimits, limit_names

    given = {name: getattr(args, name) for name in limit_names() if getattr(args, name) is not None}
    if not (args.soak or given):
        return None
    return replace(SoakLimits(), **given)


def _replay(args: argparse.Namespace) -> int:
    """Replay a recorded server session (``--replay FILE``); 0 when it ends in the recorded state."""
    from twig_ecs.server.replay import replay

    progress = Progress(sys.stderr, "replay")
    try:
        result = replay(args.replay, progress=progress)
    finally:
        progress.done()
    if args.report == "json":
        print(json.dumps(result, indent=2))
    else:
        verdict = "same as recorded" if result["match"] else "DIFFERS from the recorded"
        print(f"{result['scene']}: replayed {result['commands']} commands over {result['frames']} frames; "
              f"state {result['state_hash']} ({verdict} {result['recorded_state_hash']})")  # fmt: skip
        if result["diverged"]:
            diverged = result["diverged"]
            print(f"{diverged} command(s) succeeded or failed unlike the recording", file=sys.stderr)
    return 0 if result["match"] else 1


def _add_soak_args(p: argparse.ArgumentParser) -> None:
    from twig_ecs.soak import SoakLimits

    d = SoakLimits()
    g = p.add_argument_group("soak", "check physics health at every step; exit 1 at the first limit crossed")
    g.add_argument("--soak", action="store_true", help="enforce the limits below (defaults in brackets)")
    for flag, name, unit in (("--max-speed", "max_speed", "m/s, any node"),
                             ("--min-y", "min_y", "m, lowest node"),
                             ("--max-penetration", "max_penetration", "m, capsule overlap after a step"),
                             ("--max-link-error", "max_link_error", "|len-rest|/rest"),
                             ("--max-energy", "max_energy", "J, kinetic energy of the world")):  # fmt: skip
        g.add_argument(flag, dest=name, type=float, default=None, metavar="X",
                       help=f"{unit} [{getattr(d, name):g}]")  # fmt: skip


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``twig``."""
    parser = argparse.ArgumentParser(
        prog="twig",
        description="twig-ecs: procedural character animation with believable physical interactions.",
    )
    from twig_ecs.version import __version__

    parser.add_argument("--version", action="version", version=f"twig-ecs {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("validate", help="check scene/template YAML files and report errors")
    p.add_argument("files", nargs="+", metavar="FILE", help="scene or template files (or scene names)")
    p.add_argument("--content", action="append", default=[], metavar="DIR",
                   help="extra folder of body templates and scenes (repeatable)")  # fmt: skip
    p.add_argument("--trust", action="store_true",
                   help="accept modules only --trust lets run (validate runs no plug-in code)")  # fmt: skip
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser("run", help="run a scene headless and report on it")
    _add_scene_args(p, scene_optional=True)
    p.add_argument("--seconds", type=positive_seconds, default=10.0, help="simulated seconds (default 10)")
    p.add_argument("--report", choices=["text", "json"], default="text", help="report format")
    p.add_argument("--trace", metavar="FILE.csv", help="write a per-step trace of every character")
    p.add_argument("--plot", metavar="FILE.png", help="plot distance to caregiver and anxiety over time")
    p.add_argument("--save", metavar="FILE", help="write a snapshot of the world at the end of the run")
    p.add_argument("--load", metavar="FILE", help="start from a snapshot instead of a SCENE (--seconds more)")
    p.add_argument("--replay", metavar="FILE", help="replay a session recorded by 'twig serve --record'")
    _add_soak_args(p)
    p.set_defaults(func=cmd_run)

    p = sub.add_parser(
        "sweep", help="run a scene over many seeds and parameter values: a row per run (docs/sweeps.md)"
    )
    p.add_argument("scene", help=_scene_help())
    p.add_argument("--seeds", default="0", help="seeds and ranges, e.g. 0-199 or 1,5,9 (default 0)")
    p.add_argument("--set", dest="sweep", action="append", default=[], metavar="NAME=V1,V2,...",
                   help="values to sweep of a scene parameter or a dotted path, e.g. "
                   "attachment.safe_distance=2,3,4 (repeatable: the product is run)")  # fmt: skip
    p.add_argument(
        "--seconds", type=positive_seconds, default=60.0, help="simulated seconds a run (default 60)"
    )
    p.add_argument("-o", "--output", default="sweep.csv", metavar="FILE.csv|FILE.parquet",
                   help="the table, one row per run (default sweep.csv)")  # fmt: skip
    p.add_argument(
        "--metric",
        action="append",
        default=[],
        metavar="DOTTED.PATH",
        help="keep only these report figures (e.g. characters.small_child.hugs; repeatable)",
    )
    p.add_argument(
        "--plot",
        metavar="FILE.png",
        help="draw the share of runs with the first --metric above 0, by the first --set's value",
    )
    p.add_argument("--workers", type=int, default=None, help="worker processes (default: one per core)")
    p.add_argument(
        "--cluster",
        metavar="tcp://HOST:PORT",
        help="run on the Dask cluster with this scheduler instead (pip install 'twig-ecs[cluster]')",
    )
    p.add_argument("--content", action="append", default=[], metavar="DIR",
                   help="extra folder of body templates and scenes (repeatable)")  # fmt: skip
    p.set_defaults(func=cmd_sweep, seed=0)

    from twig_ecs.bench.run import CASES, SIZES

    p = sub.add_parser("bench", help="time step costs by system, beside MuJoCo (docs/performance.md)")
    p.add_argument("--cases", type=_list(str, CASES), default=CASES, metavar="LIST",
                   help="comma-separated: " + ",".join(CASES) + " (default all)")  # fmt: skip
    p.add_argument("--sizes", type=_list(int), default=SIZES, metavar="LIST",
                   help="crowd and pile sizes (default " + ",".join(map(str, SIZES)) + ")")  # fmt: skip
    p.add_argument("--steps", type=int, default=300, help="timed steps per case (default 300)")
    p.add_argument("--warmup", type=int, default=60, help="untimed steps first (default 60)")
    p.add_argument("--no-mujoco", action="store_true", help="skip the MuJoCo comparison")
    p.add_argument("--json", action="store_true", help="print JSON instead of tables")
    p.set_defaults(func=cmd_bench)

    for module in ("twig_ecs.graphics.cli", "twig_ecs.server.cli", "twig_ecs.export"):
        try:
            register_commands = importlib.import_module(module).register_commands
        except ImportError:  # a part not built in this checkout
            continue
        register_commands(sub, _add_scene_args)
    from twig_ecs.walklab import register_commands as register_walklab

    register_walklab(sub)
    return parser


def _unknown_arguments(parser: argparse.ArgumentParser, args: argparse.Namespace, extra: list[str]) -> None:
    """Exit with the subcommand's usage, naming the unknown arguments (and a likely meant option)."""
    import difflib

    command = getattr(args, "command", None)
    sub = next((a for a in parser._subparsers._group_actions if a.choices and command in a.choices), None)
    target = sub.choices[command] if sub is not None else parser
    options = [o for action in target._actions for o in action.option_strings]
    hints = []
    for word in extra:
        if word.startswith("-"):
            close = difflib.get_close_matches(word.split("=")[0], options, n=1, cutoff=0.5)
            if close:
                hints.append(f"{word.split('=')[0]}: did you mean {close[0]}?")
    message = f"unrecognized arguments: {' '.join(extra)}" + (f" ({'; '.join(hints)})" if hints else "")
    target.error(message)


#: Commands that compile a first run's kernels up front with progress on stderr
#: (``play`` shows it in its window; ``bench`` times the compile itself).
PREPARED_COMMANDS = ("run", "render", "serve", "sweep")


def _prepare_kernels(args: argparse.Namespace) -> None:
    """Compile the kernels of the scene a command is about to run, if not cached, saying so."""
    from twig_ecs import kernels

    if not kernels.needs_build():
        return
    source = getattr(args, "scene", None) or "schoolyard"  # --load / --replay: the usual kernels
    kernels.prepare(source, seed=args.seed, content=args.content, parameters=args.parameters)


@functools.cache
def _parser() -> argparse.ArgumentParser:
    """The parser :func:`main` reads with, built once a process (2.7 ms, most of a ``twig
    validate`` called in-process): parsing leaves it as it was, each call gets new arguments."""
    return build_parser()


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``twig`` console script."""
    parser = _parser()
    argv = _join_negative_values(list(sys.argv[1:] if argv is None else argv), ("--camera",))
    args, extra = parser.parse_known_args(argv)
    if extra:  # say it in the subcommand's words, not with the top-level usage
        _unknown_arguments(parser, args, extra)
    args.parameters = scene_parameters(args)
    if not getattr(args, "func", None):
        parser.print_help()
        return 0
    try:
        with trusting(getattr(args, "trust", False)):  # --trust: this command's files may run code
            if args.command in PREPARED_COMMANDS:
                _prepare_kernels(args)  # its workers load the scene under the same trust
            return int(args.func(args) or 0)
    except TwigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


def _join_negative_values(argv: list[str], options: tuple[str, ...]) -> list[str]:
    """``--camera -4.45,1.4,2.8@...`` as ``--camera=-4.45,...``: argparse takes a value that
    starts with '-' (and is not one plain number) for an option and says "expected one argument"."""
    out: list[str] = []
    for arg in argv:
        if out and out[-1] in options and arg[:1] == "-" and arg[1:2].isdigit():
            out[-1] = f"{out[-1]}={arg}"
        else:
            out.append(arg)
    return out


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
