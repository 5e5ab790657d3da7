"""How the kernels' worker threads wait: asleep, not spinning, so a busy machine costs little.

numba runs ``parallel=True`` kernels on an OpenMP pool here (its ``omp`` threading layer:
GNU libgomp). libgomp's default is to *spin* at the end of every parallel region, waiting
for work, for up to a few hundred thousand iterations before it sleeps. On a quiet machine
that saves a wake-up; on a machine whose cores are busy with other programs - every
user's - the spinning threads take the cores the working ones need, and a region must
wait for a thread the OS has descheduled. Measured on this project's 2-core box with two
CPU-bound processes beside it (``benchmarks/busy_machine.py``): a 300-walker crowd took
28-81 ms a step with spinning threads, 5 ms with sleeping ones and 3-17 ms on one thread;
100 approachers 22 ms, 2.7 ms and 3.3 ms.

The price is paid on a quiet machine: waking sleeping threads costs each parallel region,
so there 100 approachers take 4.2 ms a step against 1.6 spinning or on one thread, and a
300-walker crowd 3.9 against 2.7-2.8 (end of session 13). Threads should be used only where
they pay and while a core is idle - the open half of issue 33.

:func:`configure_threads` chooses the passive wait (``OMP_WAIT_POLICY=PASSIVE``) unless
the user set a policy. It must run before the OpenMP library is loaded, which numba does
at the first parallel kernel call: :func:`twig_ecs.kernelcache.configure_cache` calls it,
and every kernel module calls that first.
"""

from __future__ import annotations

import os

#: The OpenMP environment twig sets when the user has not: threads sleep when idle.
PASSIVE_WAIT = {"OMP_WAIT_POLICY": "PASSIVE"}


def configure_threads() -> dict[str, str]:
    """Make idle kernel threads sleep rather than spin (unless the user chose); returns what was set."""
    chosen = {}
    for key, value in PASSIVE_WAIT.items():
        if key not in os.environ:
            os.environ[key] = value
            chosen[key] = value
    return chosen
