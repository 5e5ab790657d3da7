"""How many threads the kernels use, and how idle ones wait: only threads that pay, asleep when idle.

The link and limit passes of a scene with :data:`PARALLEL_BODIES` bodies can split across
numba's threads (``systems/constrain.py``: bodies are projected at once and come out to the
last bit as one after the other would leave them, so the thread count never changes a
result). Whether that pays depends on the scene's size and on the machine's load, which
no rule of thumb knows - so each scene *measures* it (:class:`ThreadChoice`): now and then
it times a few steps on one thread and on all of them, taking turns, and keeps the faster.

Why not just use the threads: numba's parallel region starts and ends dozens of times a
step (once per run of bodies per relaxation pass). On a busy machine - every user's - a
region waits at its end for a thread the OS has descheduled; on this project's 2-core box
with two CPU-bound processes beside it, 100 approachers stepped 2.5x slower on two threads
than on one (end of session 13, ``benchmarks/busy_machine.py``). On a quiet machine the
sleeping threads' wake-ups cost each region, so threads pay only for large scenes.

How idle threads wait: numba runs ``parallel=True`` kernels on an OpenMP pool here (its
``omp`` threading layer, GNU libgomp; ``tbb`` is not installed and ``workqueue`` may not be
entered from two threads at once). libgomp's default is to *spin* at the end of every
region for up to a few hundred thousand iterations before it sleeps; on a busy machine
the spinning threads take the cores the working ones need (a 300-walker crowd: 28-81 ms a
step spinning, 5 ms sleeping, 3-17 ms on one thread). :func:`configure_threads` chooses the
passive wait (``OMP_WAIT_POLICY=PASSIVE``) unless the user set a policy. It must run before
the OpenMP library is loaded, which numba does at the first parallel kernel call:
:func:`twig_ecs.kernelcache.configure_cache` calls it, and every kernel module calls that
first. (A bounded spin, ``GOMP_SPINCOUNT`` 10 000 or 100 000, was 1.8x-80x slower than one
thread on the loaded box: any spinning costs there.)

``TWIG_THREADS`` (environment) fixes the choice: a number of threads for every scene large
enough to split, instead of ``auto``. ``NUMBA_NUM_THREADS`` caps it as before.
"""

from __future__ import annotations

import os
import statistics
import threading

from twig_ecs.errors import TwigError

#: The OpenMP environment twig sets when the user has not: threads sleep when idle.
PASSIVE_WAIT = {"OMP_WAIT_POLICY": "PASSIVE"}

#: Bodies from which the link and limit passes may split by body across threads (read by
#: ``systems/constrain.py``); below it no trial is run. A parallel region's start costs more
#: than a small scene's pass: on 2 cores, with threads that spun, the schoolyard (22 bodies)
#: stepped 8% slower on two threads, 30 approachers 7% faster, 100 over 20% (then).
PARALLEL_BODIES = 32

#: Steps a scene takes before its first trial (the first ones link kernels and settle).
FIRST_TRIAL = 5
#: Steps between trials; each trial that keeps one thread doubles the wait, up to LONGEST_WAIT
#: (a trial's steps on the slower setting cost a few percent of the steps between trials).
TRIAL_EVERY = 240
LONGEST_WAIT = 8 * TRIAL_EVERY
#: A trial: blocks of TRIAL_BLOCK steps on one thread (1) and on all (0), in this order
#: (ABBAAB: a drift in the load meets both alike).
TRIAL_ORDER = (1, 0, 0, 1, 1, 0)
TRIAL_BLOCK = 3
#: More threads are kept only if their median step is this much faster than one thread's:
#: a tie goes to one thread, which leaves the other cores to the user's other programs.
MARGIN = 0.05
#: On more threads, this many steps in a row slower than SLOWER x the last trial's median on
#: them start a trial at once (the machine got busy since).
GIVE_UP = 3
SLOWER = 1.5


class ThreadsError(TwigError):
    """A ``TWIG_THREADS`` that is neither ``auto`` nor a whole number of threads."""


def configure_threads() -> dict[str, str]:
    """Make idle kernel threads sleep rather than spin (unless the user chose); returns what was set."""
    chosen = {}
    for key, value in PASSIVE_WAIT.items():
        if key not in os.environ:
            os.environ[key] = value
            chosen[key] = value
    return chosen


def usable_cpus() -> int:
    """The CPUs this process may run on (its affinity where the system keeps one)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # (not on macOS or Windows)
        return os.cpu_count() or 1


def usable_threads() -> int:
    """numba's threads, but no more than the CPUs this process may run on."""
    import numba  # (here: this module is imported before numba's cache is configured)

    return max(1, min(numba.config.NUMBA_NUM_THREADS, usable_cpus()))


def fixed_threads(value: str | None = None) -> int | None:
    """The thread count ``TWIG_THREADS`` fixes (``value``: instead of the environment's), or
    None for ``auto`` (the default: measured)."""
    text = os.environ.get("TWIG_THREADS", "auto") if value is None else value
    text = text.strip().lower()
    if text in ("", "auto"):
        return None
    if not text.isdigit() or int(text) < 1:
        raise ThreadsError(f"TWIG_THREADS={text!r}: give 'auto' (measure which pays) or a number of threads, "
                           "such as 1 or 2")  # fmt: skip
    return int(text)


#: The thread count last set for the main thread (numba's is per calling thread).
_main_threads: int | None = None


def _use(n: int) -> None:
    """Set numba's thread count for the main thread's next parallel regions, if it differs."""
    global _main_threads
    if _main_threads != n:
        import numba

        numba.set_num_threads(n)
        _main_threads = n


class ThreadChoice:
    """How many threads one scene's steps use: one, or all that are usable, whichever its own
    steps were faster on when last tried.

    :meth:`begin` before a step sets numba's count (on the main thread only: numba's pool
    is not entered from others, whose steps run on one thread anyway); :meth:`end` after it
    takes the step's wall time. A trial times alternating blocks of steps (``TRIAL_ORDER``)
    and moves to all threads only if their median is ``MARGIN`` faster in two trials in a
    row. Which count a step uses never changes what it computes.
    """

    def __init__(self, most: int | None = None, fixed: int | None = None) -> None:
        """``most``: the threads to try (default: :func:`usable_threads`); ``fixed``: always
        this many (default: ``TWIG_THREADS``'s choice, ``auto`` measuring)."""
        self.most = usable_threads() if most is None else most
        self.fixed = fixed_threads() if fixed is None else fixed  # (None: measure)
        self.threads = 1  # the choice between trials
        self.steps = 0  # steps taken (on the main thread, by a scene big enough to split)
        self.threaded = 0  # ... of them on more than one thread
        self.trials = 0
        self.last_trial: dict[int, float] = {}  # median seconds a step by thread count
        self._wait = TRIAL_EVERY
        self._next_trial = FIRST_TRIAL
        self._plan: list[int] = []  # thread counts of the trial steps still to come
        self._times: dict[int, list[float]] = {}
        self._now = 0  # this step's count; 0: not counted (another thread, a small scene)
        self._trying = False  # this step is a trial's
        self._confirming = False  # the last trial found threads faster: the next one checks
        self._slow = 0

    def begin(self, bodies: int) -> int:
        """Set the thread count for a step of a scene with ``bodies`` bodies; returns it."""
        if threading.current_thread() is not threading.main_thread():
            self._now = 0
            return 1
        if bodies < PARALLEL_BODIES or self.most == 1:
            self._now = 0
            _use(1)  # (one count per scene keeps its constraint plan: see constrain.constraints_of)
            return 1
        self._trying = False
        if self.fixed is not None:
            n = min(self.fixed, self.most)
        else:
            if not self._plan and self.steps >= self._next_trial:
                self._plan = [one or self.most for one in TRIAL_ORDER for _ in range(TRIAL_BLOCK)]
                self._times = {1: [], self.most: []}
            self._trying = bool(self._plan)
            n = self._plan[0] if self._trying else self.threads
        self._now = n
        _use(n)
        return n

    def end(self, seconds: float) -> None:
        """Take the wall time of the step :meth:`begin` set up."""
        n = self._now
        if not n:
            return
        self.steps += 1
        self.threaded += n > 1
        if self._trying:
            self._times[self._plan.pop(0)].append(seconds)
            if not self._plan:
                self._decide()
        elif n > 1 and self.fixed is None:
            self._slow = self._slow + 1 if seconds > SLOWER * self.last_trial[n] else 0
            if self._slow >= GIVE_UP:
                self._next_trial = self.steps  # busy now: try again at once
                self._slow = 0

    def _decide(self) -> None:
        """Keep the faster setting of the trial just run; set when to try again. A move from one
        thread to more needs two trials in a row that find threads faster: one trial's few
        steps on a shared machine can be unlucky, and threads that do not pay cost much more
        (2.5x, 100 approachers) than one thread where threads would pay (a few tens of %)."""
        self.trials += 1
        self.last_trial = {n: statistics.median(t) for n, t in self._times.items()}
        one, many = self.last_trial[1], self.last_trial[self.most]
        faster = many < (1.0 - MARGIN) * one
        self._slow = 0
        if faster and self.threads == 1 and not self._confirming:
            self._confirming = True
            self._next_trial = self.steps  # (again at once)
            return
        self._confirming = False
        kept_one = self.threads == 1
        self.threads = self.most if faster else 1
        # one thread again: the machine or the scene is as it was, so look less often
        self._wait = min(2 * self._wait, LONGEST_WAIT) if kept_one and self.threads == 1 else TRIAL_EVERY
        self._next_trial = self.steps + self._wait

    def summary(self) -> dict:
        """What was chosen: the share of counted steps on more threads, the trials and the last
        one's median step (ms) by thread count."""
        return {
            "threads": self.threads,
            "most": self.most,
            "fixed": self.fixed,
            "threaded_share": self.threaded / self.steps if self.steps else 0.0,
            "trials": self.trials,
            "last_trial_ms": {str(n): s * 1e3 for n, s in self.last_trial.items()},
        }
