"""Where the runs execute: local processes (joblib / loky) or Ray. Scheduling is theirs.

Both take a function and a list of argument tuples and yield results as runs finish (in
completion order), so the driver can show progress and write results while others still run.

* ``local``: ``joblib.Parallel(n_jobs=jobs, backend="loky")``, one run per task. ``jobs=1``
  runs in this process (no worker start-up; handy for debugging).
* ``ray``: one Ray task per run (``num_cpus=1``) on a local Ray instance started for the sweep
  (``jobs`` CPUs), or on the cluster at ``address`` / ``$RAY_ADDRESS``. A local instance's
  workers run at normal priority: Ray nices its workers to 15, so any other busy process on
  the machine starved them (four 0.3 s runs took 260 s beside a busy pytest worker on 2 cores;
  a worker's pure-Python loop ran 4x slower). On a multi-node cluster
  the output directory should be on a shared file system (each run writes its own outputs
  where it executes; the driver still receives and records every run's metrics).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator
from typing import Any

from humimic.errors import InputError

BACKENDS = ("local", "ray")
INSTALL_HINT = "pip install 'humimic[cluster]'"


class BackendUnavailable(InputError):
    """The chosen backend cannot be used here (e.g. ray is not installed)."""


def default_jobs() -> int:
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
               else os.cpu_count() or 1)


def local_map(fn: Callable, args: list[tuple], jobs: int) -> Iterator[Any]:
    """``fn(*a)`` for each ``a`` in ``args`` on ``jobs`` loky worker processes."""
    if not args:
        return
    if jobs <= 1:
        for a in args:
            yield fn(*a)
        return
    from joblib import Parallel, delayed

    parallel = Parallel(n_jobs=min(jobs, len(args)), backend="loky", batch_size=1,
                        return_as="generator_unordered")
    yield from parallel(delayed(fn)(*a) for a in args)


def import_ray():
    """The ``ray`` module, or :class:`BackendUnavailable` with the install hint."""
    try:
        import ray
    except ImportError:
        raise BackendUnavailable(
            f"--backend ray: ray is not installed; install the cluster extra: {INSTALL_HINT}"
        ) from None
    return ray


def ray_map(fn: Callable, args: list[tuple], jobs: int, address: str | None = None
            ) -> Iterator[Any]:
    """``fn(*a)`` for each ``a`` as Ray tasks; local Ray unless ``address``/``$RAY_ADDRESS``."""
    ray = import_ray()
    if not args:
        return
    address = address or os.environ.get("RAY_ADDRESS") or None
    started = not ray.is_initialized()
    if started:
        kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False,
                                  "logging_level": "WARNING"}
        if address is None:
            kwargs["num_cpus"] = jobs
            kwargs["_system_config"] = {"worker_niceness": 0}  # see the module's docstring
        try:
            ray.init(address=address, **kwargs)
        except ConnectionError as exc:
            raise BackendUnavailable(f"--backend ray: cannot connect to the Ray cluster at "
                                     f"{address!r}: {exc}") from None
    try:
        task = ray.remote(num_cpus=1, max_retries=1)(fn)
        pending = [task.remote(*a) for a in args]
        while pending:
            done, pending = ray.wait(pending, num_returns=1)
            yield ray.get(done[0])
    finally:
        if started:
            ray.shutdown()


def check_backend(backend: str, address: str | None = None) -> None:
    """Raise :class:`BackendUnavailable` unless ``backend`` can run here."""
    if backend not in BACKENDS:
        raise BackendUnavailable(f"unknown backend {backend!r}; allowed: {', '.join(BACKENDS)}")
    if backend == "local" and address:
        raise BackendUnavailable("--address is for --backend ray")
    if backend == "ray":
        import_ray()


def run_map(backend: str, fn: Callable, args: list[tuple], jobs: int,
            address: str | None = None) -> Iterator[Any]:
    """Results of ``fn(*a)`` for every ``a`` in ``args``, in completion order."""
    check_backend(backend, address)
    if backend == "ray":
        return ray_map(fn, args, jobs, address)
    return local_map(fn, args, jobs)
