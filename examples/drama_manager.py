"""A tiny drama manager: stages a short story in the schoolyard through ``twig serve``.

Start the server, then run this::

    twig serve schoolyard --scripted          # in one terminal
    python examples/drama_manager.py          # in another

Act 1: the big child fetches the ball for the small one (carry). Act 2: they quarrel
(grapple). Act 3: they make up with a hug while the parent waves. Every notification the
server sends is printed as it arrives. ``--fast`` pauses the server and steps it as
fast as it can compute (the same story, deterministic, in a fraction of the time);
``--spawn-server`` starts its own server for the run.
"""

from __future__ import annotations

import argparse
import sys
import time

from twig_ecs.client import Client, Notification, RemoteError, spawn_server

#: Longest a scene of the story may take (simulated seconds) before we move on.
ACT_LIMIT = 40.0


def show(note: Notification) -> None:
    """Print one notification on a line."""
    kind = note.kind
    if kind in ("goal.done", "goal.failed"):
        what = f"{note['character']} {note['behavior']} (goal {note['goal']})"
        if kind == "goal.failed":
            what += f": {note['reason']}"
    elif kind == "behavior.changed":
        what = f"{note['character']}: {note['old']} -> {note['new']}"
    elif kind in ("grab", "release"):
        verb = "takes" if kind == "grab" else "lets go of"
        what = f"{note['character']} {note['hand'] or ''} hand {verb} {note['target']}"
    elif kind == "pain":
        what = f"{note['body']} hurt by {note['source']} ({note['energy']:.1f} J, level {note['level']:.1f})"
    else:
        what = str(dict(note))
    print(f"[{note['time']:6.2f} s] {kind:<16} {what}", flush=True)


class Director:
    """Gives goals and waits for their ends, in real time or by stepping a paused server."""

    def __init__(self, twig: Client, fast: bool) -> None:
        self.twig = twig
        self.fast = fast

    def say(self, text: str) -> None:
        print(f"\n== {text}", flush=True)

    def goal(self, method: str, **params) -> Notification | None:
        """Give a goal and wait for its end (printing everything that happens meanwhile)."""
        try:
            goal = self.twig.call(method, **params)["goal"]
        except RemoteError as exc:
            print(f"   refused: {exc}")
            return None
        print(f"   {params['character']}: {method} {params.get('target', '')} -> goal {goal}", flush=True)
        return self.wait(goal)

    def wait(self, goal: int) -> Notification | None:
        ended = None

        def sort(note: Notification) -> None:
            nonlocal ended
            show(note)
            if note.kind in ("goal.done", "goal.failed") and note["goal"] == goal:
                ended = note

        if not self.fast:
            self.twig.wait_for(lambda n: False, timeout=0, on_other=sort)  # what is already here
            if ended is None:
                try:
                    ended = self.twig.wait_goal(goal, timeout=ACT_LIMIT, on_other=show)
                    show(ended)
                except TimeoutError:
                    pass  # the act ran out of time: the caller says so
            return ended
        for _ in range(int(ACT_LIMIT * 2)):  # half a second of simulated time at a time
            self.twig.step(n=30)
            while (note := self.twig.next_notification(timeout=0)) is not None:
                sort(note)
            if ended is not None:
                return ended
        return None

    def pause(self, seconds: float) -> None:
        """Let the scene breathe (printing what happens)."""
        if self.fast:
            self.twig.step(n=int(seconds * 60))
            while (note := self.twig.next_notification(timeout=0)) is not None:
                show(note)
        else:
            end = time.monotonic() + seconds
            while (left := end - time.monotonic()) > 0:
                note = self.twig.next_notification(timeout=left)
                if note is not None:
                    show(note)


def stage(twig: Client, fast: bool) -> None:
    """The story."""
    d = Director(twig, fast)
    print(f"connected: {twig.status()}")
    names = {e["name"] for e in twig.list_entities()}
    missing = {"parent", "big_child", "small_child", "ball"} - names
    if missing:
        raise SystemExit(f"this story needs the schoolyard; the scene lacks {', '.join(sorted(missing))}")
    twig.subscribe(events=["goal.done", "goal.failed", "behavior.changed", "grab", "release", "pain"])
    if fast:
        twig.pause()
    for who in ("parent", "big_child", "small_child"):  # a scripted story: nobody wanders off
        twig.set_autonomous(character=who, autonomous=False)

    d.say("Act 1: the small child puts the doll down; the big child fetches the ball for it")
    twig.release(character="small_child")
    twig.look_at(character="small_child", target="big_child")
    twig.look_at(character="parent", target="big_child")
    d.goal("carry", character="big_child", target="ball", to="small_child")
    d.pause(1.0)

    d.say("Act 2: the ball is not handed over - a quarrel")
    d.goal("grapple", character="big_child", target="small_child", duration=2.0)
    twig.look_at(character="parent", target="small_child")
    d.pause(1.0)

    d.say("Act 3: they make up with a hug; the parent waves")
    twig.release(character="big_child")
    d.goal("approach", character="big_child", target="small_child", stop_distance=0.5)
    end = d.goal("hug", character="big_child", target="small_child", duration=2.0)
    if end is None or end.kind != "goal.done":
        print("   (again, the other way round)")
        d.goal("hug", character="small_child", target="big_child", duration=2.0)
    d.goal("gesture", character="parent", name="wave", duration=1.5)

    state = twig.get_state()
    print(f"\nThe end, at {state['time']:.2f} s simulated.")
    for who in ("parent", "big_child", "small_child"):
        s = state["entities"][who]
        x, _, z = s["position"]
        where = f"at ({x:5.2f}, {z:5.2f})"
        print(f"   {who:<12} {where} {s['posture']}, pain {s['pain']:.2f}, holding {s['holding']}")
    if fast:
        twig.resume()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--port", type=int, default=7470)
    parser.add_argument("--token", default=None, help="the server's token, if it has one")
    parser.add_argument("--fast", action="store_true", help="pause the server and step it (deterministic)")
    parser.add_argument("--spawn-server", action="store_true", help="start a server for this run")
    args = parser.parse_args(argv)
    proc = None
    if args.spawn_server:
        proc, args.port = spawn_server("schoolyard", "--scripted", echo=True)
    try:
        with Client(args.host, args.port, token=args.token, timeout=60) as twig:
            stage(twig, args.fast)
    except ConnectionRefusedError:
        print(f"no server on {args.host}:{args.port}: start 'twig serve schoolyard --scripted' first")
        return 1
    finally:
        if proc is not None:
            proc.terminate()
            proc.wait(timeout=20)
    return 0


if __name__ == "__main__":
    sys.exit(main())
