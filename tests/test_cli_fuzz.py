"""Fuzzing the command line with files (issue 31): no input file ends in a traceback.

Files of every kind the CLI reads - mutated built-in scenes and body templates, random
YAML, mutated replays, mutated snapshot bytes (some with their checksum made right again)
- go through the real entry point, ``twig_ecs.cli.main``, as ``twig validate``,
``twig run``, ``twig run --replay`` and ``twig run --load``; a few through a real
``python -m twig_ecs`` process. Each must exit 0, 1 or 2, with no traceback on stderr.

The files come from a seeded generator, so CI sees the same ones every run
(:data:`DEFAULT_FILES` of them, about 30 s); ``TWIG_FUZZ_EXAMPLES=1000`` runs that many,
and ``TWIG_FUZZ_SEED`` picks another seed (docs/reliability.md).
"""

from __future__ import annotations

import contextlib
import hashlib
import io
import json
import os
import random
import re
import subprocess
import sys
import traceback
from collections.abc import Callable
from pathlib import Path

import pytest

from twig_ecs import Scene
from twig_ecs.cli import main
from twig_ecs.library import builtin_dir
from twig_ecs.replay import MAX_FRAMES
from twig_ecs.scenefile import CHARACTER_KEYS, ENTITY_KEYS, SCENE_KEYS, SETTINGS_KEYS
from twig_ecs.templates import LINK_KEYS, NODE_KEYS, TEMPLATE_KEYS

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_FILES = 1000
FILES = int(os.environ.get("TWIG_FUZZ_EXAMPLES", "0")) or DEFAULT_FILES
SEED = int(os.environ.get("TWIG_FUZZ_SEED", "0"))
#: Exit codes the CLI may give: ok, a failed check (validate, soak, replay mismatch), an error.
EXIT_CODES = (0, 1, 2)
#: Simulated seconds for each ``twig run`` of a fuzzed file (a few steps).
RUN = ("--seconds", "0.05")

BUILTIN_SCENES = sorted((builtin_dir() / "scenes").glob("*.yaml"))
BUILTIN_BODIES = sorted((builtin_dir() / "bodies").glob("*.yaml"))
KEYS = SCENE_KEYS + ENTITY_KEYS + CHARACTER_KEYS + SETTINGS_KEYS + TEMPLATE_KEYS + NODE_KEYS + LINK_KEYS
#: Values a mutation puts where a number, a name or a key stood: the kinds that found bugs.
HOSTILE_VALUES = (
    "0", "-1", "1e-300", "5e-324", "1e300", "-1e308", "1e999", ".nan", ".inf", "-.inf", "1:30", "59:59:59.5",
    "0x" + "f" * 120, "9" * 400, "9" * 5000, "''", "~", "true", "[]", "{}", "[1, 2]", "[hub, hub]",
    '"\\ud800"', "&a [1, 2]", "*a", "!!python/object/apply:os.system [echo hi]", "!!binary aGk=",
    "!!float 1:2:3.5", "!!int 99:99", "!!timestamp x", "!!bool x", "!!int _",
    "'$(round(1, -100000000))'", "'$(10**64**64)'", "'$(count * 1e300)'",
    "'$nope'", "2001-12-14", "humanoid", "ball", "x.py:Nope", "twig_ecs.system:System", "../../etc/passwd",
)  # fmt: skip
SNIPPETS = ("{", "}", "[", "]", ":", "- ", "? ", "&a ", "*a", "---\n", "...\n", "%TAG ! x\n", "\t", "#",
            '"', "'", "\\", "|\n", ">\n", "\x00", "\ufeff", "\n  - ", ": :")  # fmt: skip


# -- generators: each returns (file name, bytes, CLI arguments after the file) -------------------


def mutate_text(rng: random.Random, text: str) -> str:
    """1-4 mutations of a YAML text: values, lines, keys, indentation, stray syntax."""
    for _ in range(rng.randint(1, 4)):
        lines = text.splitlines(keepends=True) or [""]
        k = rng.randrange(len(lines))
        op = rng.randrange(8)
        if op == 0:  # a number becomes a hostile value
            numbers = list(re.finditer(r"-?\d+(\.\d+)?(e-?\d+)?", text))
            if numbers:
                m = rng.choice(numbers)
                text = text[: m.start()] + rng.choice(HOSTILE_VALUES) + text[m.end() :]
                continue
        if op == 1:  # a value after a colon becomes a hostile value
            value = rng.choice(HOSTILE_VALUES)
            lines[k] = re.sub(r":\s+\S.*", lambda _, v=value: ": " + v, lines[k], count=1)
        elif op == 2:
            del lines[k]
        elif op == 3:
            lines.insert(k, lines[rng.randrange(len(lines))])
        elif op == 4:  # a key renamed
            key = rng.choice(KEYS)
            lines[k] = re.sub(r"\w+:", lambda _, key=key: key + ":", lines[k], count=1)
        elif op == 5:  # indentation changed
            lines[k] = " " * rng.choice((0, 1, 2, 3, 4, 8)) + lines[k].lstrip(" ")
        elif op == 6:  # stray syntax
            at = rng.randrange(len(lines[k]) + 1)
            lines[k] = lines[k][:at] + rng.choice(SNIPPETS) + lines[k][at:]
        else:  # a name where another stood
            old = rng.choice(("humanoid", "ball", "parent", "pelvis", "hub", "l_knee"))
            lines[k] = lines[k].replace(old, rng.choice(("ragdoll", "nobody", "bench", "head", "rim0")), 1)
        text = "".join(lines)
    return text


def mutate_bytes(rng: random.Random, data: bytes, count: int = 4) -> bytes:
    """A few byte-level changes: replaced, inserted, removed, or cut off."""
    out = bytearray(data)
    for _ in range(rng.randint(1, count)):
        op = rng.randrange(4)
        at = rng.randrange(len(out) + 1)
        if op == 0 and out:
            out[min(at, len(out) - 1)] = rng.randrange(256)
        elif op == 1:
            out[at:at] = bytes(rng.randrange(256) for _ in range(rng.randint(1, 8)))
        elif op == 2:
            del out[at : at + rng.randint(1, 16)]
        else:
            del out[max(at, len(out) // 2) :]
    return bytes(out)


def scene_file(rng: random.Random, tmp: Path) -> tuple[str, bytes, list[str]]:
    text = mutate_text(rng, rng.choice(BUILTIN_SCENES).read_text())
    data = text.encode("utf-8", "surrogatepass")
    if rng.random() < 0.1:
        data = mutate_bytes(rng, data)
    return "scene.yaml", data, ([*RUN] if rng.random() < 0.1 else [])


def template_file(rng: random.Random, tmp: Path) -> tuple[str, bytes, list[str]]:
    """A mutated built-in body, alone (``twig validate``) or in a content folder a scene uses."""
    source = rng.choice(BUILTIN_BODIES)
    text = mutate_text(rng, source.read_text())
    if rng.random() < 0.5:
        return "body.yaml", text.encode("utf-8", "surrogatepass"), []
    folder = tmp / "content"
    folder.mkdir(exist_ok=True)
    (folder / source.name).write_bytes(text.encode("utf-8", "surrogatepass"))
    name = re.search(r"^template:\s*(\S+)", source.read_text(), re.M).group(1)
    extra = ", character: true" if name == "humanoid" else ""
    scene = f"twig: 1\nname: fuzz\nentities:\n  - {{name: it, body: {name}, position: [0, 0.5, 0]{extra}}}\n"
    run = [*RUN] if rng.random() < 0.2 else []
    return "scene.yaml", scene.encode(), ["--content", str(folder), *run]


def random_value(rng: random.Random, depth: int = 0):
    """Any YAML value: scalars of every kind, lists and mappings keyed by the schema's keys."""
    roll = rng.random()
    if depth < 4 and roll < 0.25:
        return [random_value(rng, depth + 1) for _ in range(rng.randint(0, 4))]
    if depth < 4 and roll < 0.5:
        return {rng.choice(KEYS): random_value(rng, depth + 1) for _ in range(rng.randint(0, 5))}
    return rng.choice([None, True, 0, -1, 1.5, 1e300, -1e-300, float("inf"), 2**70, "", "x", "humanoid",
                       "ball", "parent", "é", [0, 1, 0], [1.0, 2.0]])  # fmt: skip


def random_mapping(rng: random.Random, keys: tuple[str, ...], most: int = 6) -> dict:
    """A mapping of some of ``keys`` (and now and then any other) to random values."""
    count = rng.randint(0, most)
    return {rng.choice(keys if rng.random() < 0.9 else KEYS): random_value(rng) for _ in range(count)}


def random_yaml(rng: random.Random, tmp: Path) -> tuple[str, bytes, list[str]]:
    """A random document shaped as a scene, a body template, or anything."""
    import yaml

    shape = rng.randrange(3)
    if shape == 0:  # a scene: entities of random keys and values
        entities = [random_mapping(rng, ENTITY_KEYS) for _ in range(rng.randint(0, 3))]
        doc = {"name": "fuzz", "entities": entities}
        if rng.random() < 0.5:
            doc["settings"] = random_mapping(rng, SETTINGS_KEYS, 3)
    elif shape == 1:  # a body template: nodes and links of random keys and values
        nodes = {f"n{k}": random_mapping(rng, NODE_KEYS, 4) | {"at": [k * 0.1, 1.0, 0.0]} for k in range(3)}
        links = [random_mapping(rng, LINK_KEYS, 4) | {"nodes": ["n0", f"n{k}"]} for k in (1, 2)]
        doc = {"template": "fuzzed", "nodes": nodes, "links": links} | random_mapping(rng, TEMPLATE_KEYS, 3)
    else:
        doc = {rng.choice(KEYS): random_value(rng) for _ in range(rng.randint(0, 6))}
    if rng.random() < 0.9:
        doc["twig"] = 1
    text = yaml.safe_dump(doc, allow_unicode=True)
    if rng.random() < 0.3:
        text = mutate_text(rng, text)
    return "random.yaml", text.encode("utf-8", "surrogatepass"), ([*RUN] if rng.random() < 0.1 else [])


REPLAY_SCENE = ("twig: 1\nname: duo\nentities:\n  - {name: ann, body: humanoid, character: true}\n"
                "  - {name: toy, body: ball, position: [1, 0.5, 1]}\n")  # fmt: skip
REPLAY_COMMANDS = [
    {"frame": 2, "method": "walk", "params": {"character": "ann", "velocity": [0.5, 0, 0]}, "error": None},
    {"frame": 5, "method": "spawn", "params": {"template": "ball", "name": "b2", "position": [0, 1, 0]},
     "error": None},
    {"frame": 8, "method": "hug", "params": {"character": "ann", "target": "toy", "duration": 1.0},
     "error": "not a figure"},
    {"frame": 9, "method": "step", "params": {"n": 3}, "error": None},
    {"frame": 12, "method": "remove", "params": {"name": "b2"}, "error": None},
    {"frame": 15, "method": "get_state", "params": {"name": "ann"}, "error": None},
]  # fmt: skip
REPLAY_VALUES = (-1, 0, 1, 2**63, 10**30, MAX_FRAMES + 1, 1.5, "x", None, True, [], {}, "\ud800",
                 float("inf"), [1, 2, 3], {"a": [[[]]]}, "ann", "toy", "nobody")  # fmt: skip


def replay_file(rng: random.Random, tmp: Path) -> tuple[str, bytes, list[str]]:
    """A short session (two bodies, six commands) with its fields, lines or bytes mutated."""
    recorded = {"path": str(tmp / "gone" / "duo.yaml"), "text": REPLAY_SCENE}
    header = {"twig_replay": 1, "scene": "duo", "seed": 0, "content": [], "autonomous": True,
              "files": {"scene": recorded, "content": {}}}  # fmt: skip
    records = [header, *[json.loads(json.dumps(c)) for c in REPLAY_COMMANDS], {"end": 20, "state_hash": "x"}]
    for _ in range(rng.randint(1, 3)):
        record = rng.choice(records)
        op = rng.randrange(5)
        if op == 0:  # a field gets a hostile value
            key = rng.choice([*record, "params", "frame", "end", "seed"])
            record[key] = rng.choice(REPLAY_VALUES)
        elif op == 1 and isinstance(record.get("params"), dict) and record["params"]:
            record["params"][rng.choice(list(record["params"]))] = rng.choice(REPLAY_VALUES)
        elif op == 2:
            records.insert(rng.randrange(len(records) + 1), rng.choice(records))
        elif op == 3 and len(records) > 1:
            del records[rng.randrange(len(records))]
        else:  # the embedded scene mutated
            recorded["text"] = mutate_text(rng, REPLAY_SCENE)
    text = "\n".join(json.dumps(r) for r in records) + "\n"
    data = text.encode("utf-8", "surrogatepass")
    if rng.random() < 0.25:
        data = mutate_bytes(rng, data)
    return "session.twigreplay", data, ["--report", "json"] if rng.random() < 0.5 else []


_SNAPSHOT: list[bytes] = []


def snapshot_bytes() -> bytes:
    """A snapshot of a small scene a few steps in (made once)."""
    if not _SNAPSHOT:
        with Scene.load("playground") as scene:
            scene.step(3)
            _SNAPSHOT.append(scene.snapshot())
    return _SNAPSHOT[0]


def snapshot_file(rng: random.Random, tmp: Path) -> tuple[str, bytes, list[str]]:
    """Snapshot bytes mutated - mostly a few bytes replaced in place, past the length checks -
    and most of them with the SHA-256 at the end made right again, to reach the payload."""
    data = bytearray(snapshot_bytes())
    if rng.random() < 0.75:
        for _ in range(rng.randint(1, 3)):
            data[rng.randrange(10, len(data) - 32)] = rng.randrange(256)
    else:
        data = bytearray(mutate_bytes(rng, bytes(data), count=2))
    data = bytes(data)
    if rng.random() < 0.75 and len(data) > 32:
        body = data[:-32]
        data = body + hashlib.sha256(body).digest()
    return "world.twigsnap", data, []


GENERATORS: dict[str, tuple[Callable, str]] = {
    "scene": (scene_file, "validate"),
    "template": (template_file, "validate"),
    "random-yaml": (random_yaml, "validate"),
    "replay": (replay_file, "--replay"),
    "snapshot": (snapshot_file, "--load"),
}
#: Each kind's share of the files (scenes and templates the most: the loader has the most to check).
SHARES = {"scene": 0.3, "template": 0.2, "random-yaml": 0.15, "replay": 0.2, "snapshot": 0.15}


def command(kind: str, path: Path, extra: list[str]) -> list[str]:
    """The ``twig`` arguments for a fuzzed file of ``kind``."""
    how = GENERATORS[kind][1]
    if how == "validate":
        if "--seconds" in extra:  # a scene to run a few steps of, not only to validate
            return ["run", str(path), *extra]
        return ["validate", str(path), *extra]
    if how == "--replay":
        return ["run", "--replay", str(path), *extra]
    return ["run", "--load", str(path), *RUN, *extra]


def fuzz_cases(count: int, seed: int) -> list[tuple[str, int]]:
    """(kind, case seed) for ``count`` files, in the kinds' shares, interleaved."""
    rng = random.Random(seed)
    kinds = [k for k, share in SHARES.items() for _ in range(round(share * count))]
    kinds = (kinds + ["scene"] * count)[:count]
    rng.shuffle(kinds)
    return [(kind, rng.randrange(2**32)) for kind in kinds]


def call_cli(args: list[str]) -> tuple[int, str]:
    """``twig ARGS`` in this process: (exit code, stderr). An exception escaping is a traceback."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = main(args)
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else 2
        except Exception:  # noqa: BLE001 - what a user would have seen
            traceback.print_exc(file=err)
            code = 1
    return code, err.getvalue()


def make_file(kind: str, case_seed: int, folder: Path) -> list[str]:
    """Write the fuzzed file of (kind, seed) into ``folder``; the CLI arguments to try it."""
    rng = random.Random(case_seed)
    name, data, extra = GENERATORS[kind][0](rng, folder)
    path = folder / name
    path.write_bytes(data)
    return command(kind, path, extra)


def run_cases(cases: list[tuple[int, str, int]], root: Path) -> None:
    """The child's loop: each case's file through the CLI; one JSON line per case on stdout."""
    for n, kind, case_seed in cases:
        folder = root / f"{n:04d}"
        folder.mkdir(exist_ok=True)
        print(json.dumps({"begin": n}), flush=True)  # a crash inside names this case
        args = make_file(kind, case_seed, folder)
        code, err = call_cli(args)
        print(json.dumps({"done": n, "code": code, "traceback": "Traceback" in err, "err": err[-600:]}),
              flush=True)  # fmt: skip


def fuzz(kinds: tuple[str, ...], root: Path, timeout: float = 1800) -> list[str]:
    """Run this seed's cases of ``kinds`` in a child process (a crash or hang is a failure too,
    named by its case; the child is started again after it); the failures, in words."""
    cases = [(n, kind, s) for n, (kind, s) in enumerate(fuzz_cases(FILES, SEED)) if kind in kinds]
    failures, left = [], cases
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), str(ROOT / "tests")])}
    while left:
        plan = root / "cases.json"
        plan.write_text(json.dumps(left))
        try:
            proc = subprocess.run([sys.executable, __file__, str(plan), str(root)], capture_output=True,
                                  text=True, timeout=timeout, env=env)  # fmt: skip
            output, ended = proc.stdout, f"died (exit code {proc.returncode}): {proc.stderr[-300:]}"
        except subprocess.TimeoutExpired as exc:
            output, ended = (exc.stdout or b"").decode(errors="replace"), f"ran past {timeout:.0f} s"
        seeds = {n: (kind, case_seed) for n, kind, case_seed in left}
        done, running = set(), None
        for line in output.splitlines():
            record = json.loads(line) if line.startswith(('{"begin"', '{"done"')) else {}
            if "begin" in record:
                running = record["begin"]
            elif "done" in record:
                done.add(record["done"])
                running = None
                if record["code"] not in EXIT_CODES or record["traceback"]:
                    kind, case_seed = seeds[record["done"]]
                    failures.append(f"{kind} #{record['done']} (seed {case_seed}): exit {record['code']}: "
                                    f"{record['err'][-300:]}")  # fmt: skip
        if running is not None:  # it crashed or hung inside this case: say so, go on after it
            kind, case_seed = seeds[running]
            failures.append(f"{kind} #{running} (seed {case_seed}): the process {ended}")
            done.add(running)
        elif len(done) < len(left):
            failures.append(f"the fuzzing process {ended}, between cases")
            break
        left = [case for case in left if case[0] not in done]
    return failures


#: The kinds the first test covers; snapshots have their own (see below).
FILE_KINDS = ("scene", "template", "random-yaml", "replay")


@pytest.mark.long  # 850 CLI calls: 6 s
def test_no_fuzzed_scene_template_yaml_or_replay_makes_the_cli_print_a_traceback(tmp_path):
    failures = fuzz(FILE_KINDS, tmp_path)
    assert not failures, f"{len(failures)} files:\n" + "\n".join(failures)


def test_no_fuzzed_snapshot_makes_the_cli_print_a_traceback(tmp_path):
    failures = fuzz(("snapshot",), tmp_path)
    assert not failures, f"{len(failures)} files:\n" + "\n".join(failures)


@pytest.mark.parametrize("kind", list(GENERATORS))
def test_fuzzed_files_through_a_real_twig_process(tmp_path, kind):
    """One file of each kind through ``python -m twig_ecs``: the real entry, exit code and stderr."""
    args = make_file(kind, SEED + 1, tmp_path)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.run([sys.executable, "-m", "twig_ecs", *args], capture_output=True, text=True,
                          timeout=120, env=env)  # fmt: skip
    assert proc.returncode in EXIT_CODES and "Traceback" not in proc.stderr, proc.stderr[-2000:]


if __name__ == "__main__":  # the child process of fuzz(): python test_cli_fuzz.py CASES.json FOLDER
    run_cases([tuple(case) for case in json.loads(Path(sys.argv[1]).read_text())], Path(sys.argv[2]))
