"""Run one function over many items: here, in local processes (joblib) or on a Dask cluster.

:func:`parallel_completed` yields each result as soon as it is done (so a caller can keep
it, see :mod:`calib_pin.studies.checkpoint`); :func:`parallel_map` returns them in order. A fault
of the machinery, not of an item, is a :class:`ParallelFault` with one line that names
it: a local worker process that died, a Dask scheduler that cannot be reached, is not a
Dask scheduler or died, no Dask worker left, a worker that died running an item. Every
wait is bounded: connecting (:data:`CONNECT_TIMEOUT_S`), the scheduler's first answer
(:data:`ANSWER_TIMEOUT_S`) and a cluster without any worker (:data:`WORKER_WAIT_S`).
Workers run the function with one BLAS thread (:mod:`threadpoolctl`).
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import os
import re
import socket
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any, TypeVar

from ..exceptions import CalibPinError
from ..util.optional import require

T = TypeVar("T")
R = TypeVar("R")

#: Longest wait to connect to a Dask scheduler, [s].
CONNECT_TIMEOUT_S = 10.0
#: Longest wait for a Dask scheduler's answer once connected, [s]: a server that accepts
#: the connection but does not answer like a scheduler in this time is not one.
ANSWER_TIMEOUT_S = 5.0
#: Longest wait while the scheduler has no worker at all (all died, or none started), [s].
WORKER_WAIT_S = 60.0
#: How often a Dask run looks at its tasks, scheduler and workers, [s].
POLL_S = 0.05


class ParallelFault(CalibPinError):
    """The machinery that runs the items failed (a worker or the scheduler), not an item."""


def error_line(error: BaseException) -> str:
    """An exception as one line: its message's first line, with its type unless it is a CalibPinError."""
    text = str(error).strip().splitlines()
    first = text[0] if text else ""
    if isinstance(error, CalibPinError):
        return first or type(error).__name__
    return f"{type(error).__name__}: {first}" if first else type(error).__name__


class _Limited:
    """``fn`` run with one BLAS/OpenMP thread (picklable, unlike a closure)."""

    def __init__(self, fn: Callable) -> None:
        self.fn = fn

    def __call__(self, item):
        from threadpoolctl import threadpool_limits

        with threadpool_limits(limits=1):
            return self.fn(item)


class _Indexed:
    """``(i, item) -> (i, fn(item))``: a result that says which item it belongs to."""

    def __init__(self, fn: Callable) -> None:
        self.fn = fn

    def __call__(self, pair: tuple[int, Any]) -> tuple[int, Any]:
        return pair[0], self.fn(pair[1])


def limited(fn: Callable[[T], R]) -> Callable[[T], R]:
    """``fn`` run with one BLAS/OpenMP thread; picklable when ``fn`` is."""
    return _Limited(fn)


def parallel_map(
    fn: Callable[[T], R], items: Sequence[T], jobs: int = 1, scheduler: str | None = None,
    *, worker_wait_s: float | None = None,
) -> list[R]:
    """``[fn(item) for item in items]``, in order, here or on workers.

    Args:
        fn: A picklable function (module level) of one item.
        items: Its arguments (picklable).
        jobs: Local worker processes (joblib, ``loky``); 1 runs in this process as a
            plain loop, with the BLAS threads left as they are.
        scheduler: Address of a running Dask scheduler (``tcp://host:8786``); when
            given, ``jobs`` is ignored and the items run on the cluster's workers.
        worker_wait_s: Longest wait while the cluster has no worker, [s] (default
            :data:`WORKER_WAIT_S`).

    An exception in ``fn`` propagates; catch it inside ``fn`` to keep the other items
    going (as :func:`calib_pin.studies.batch.run_task` does).

    Raises:
        CalibPinError: jobs below 1, a malformed scheduler address.
        ParallelFault: a worker or the scheduler failed (one line naming which).
    """
    items = list(items)
    results: list[Any] = [None] * len(items)
    for i, result in parallel_completed(fn, items, jobs, scheduler, worker_wait_s=worker_wait_s):
        results[i] = result
    return results


def parallel_completed(
    fn: Callable[[T], R], items: Sequence[T], jobs: int = 1, scheduler: str | None = None,
    *, worker_wait_s: float | None = None,
) -> Iterator[tuple[int, R]]:
    """``(i, fn(items[i]))`` for every item, each as soon as it is done (any order).

    Arguments, errors: as :func:`parallel_map`. Closing the iterator early (an exception
    or Ctrl-C in the caller) stops the workers' remaining items.
    """
    items = list(items)
    if jobs < 1:
        raise CalibPinError(f"jobs must be at least 1, got {jobs}")
    if scheduler:
        yield from _dask_completed(limited(fn), items, scheduler, WORKER_WAIT_S if worker_wait_s is None else worker_wait_s)
    elif jobs == 1 or len(items) <= 1:
        for i, item in enumerate(items):
            yield i, fn(item)
    else:
        yield from _joblib_completed(limited(fn), items, jobs)


#: loky's resource tracker (a process of its own, started with the first pool) warns on its
#: stderr about the semaphores of a worker that was killed, after calib-pin has said so in one
#: line (:class:`ParallelFault`); it is started with that warning off (the environment's
#: PYTHONWARNINGS, which it reads when it starts).
QUIET_TRACKER = "ignore::UserWarning:joblib.externals.loky.backend.resource_tracker"


def _quiet_resource_tracker() -> None:
    """Add :data:`QUIET_TRACKER` to PYTHONWARNINGS (kept: the caller's own filters)."""
    current = os.environ.get("PYTHONWARNINGS", "")
    if QUIET_TRACKER not in current.split(","):
        os.environ["PYTHONWARNINGS"] = ",".join(part for part in (current, QUIET_TRACKER) if part)


def _joblib_completed(fn: Callable, items: list, jobs: int) -> Iterator[tuple[int, Any]]:
    joblib = require("joblib")
    _quiet_resource_tracker()
    from joblib.externals.loky.process_executor import TerminatedWorkerError

    run = joblib.Parallel(n_jobs=min(jobs, len(items)), backend="loky", batch_size=1, return_as="generator_unordered")
    results = run(joblib.delayed(_Indexed(fn))((i, item)) for i, item in enumerate(items))
    try:
        yield from results
    except TerminatedWorkerError as e:
        codes = re.search(r"exit codes of the workers are \{(.*?)\}", str(e))
        why = f" (exit {codes.group(1)})" if codes else ""
        raise ParallelFault(f"a local worker process died{why}: killed, out of memory or crashed") from None
    finally:
        results.close()  # stops the remaining items when the caller stops early


def _dask_completed(fn: Callable, items: list, scheduler: str, worker_wait_s: float) -> Iterator[tuple[int, Any]]:
    distributed = require("distributed")
    _check_scheduler(scheduler)
    with _quiet_dask_logs():
        try:
            client = distributed.Client(scheduler, timeout=f"{CONNECT_TIMEOUT_S}s", set_as_default=False)
        except (OSError, TimeoutError) as e:
            raise ParallelFault(f"cannot reach the Dask scheduler at {scheduler}: {error_line(e)}") from None
        with client:
            futures = client.map(fn, items, pure=False)
            index = {future.key: i for i, future in enumerate(futures)}
            try:
                yield from _dask_results(distributed, client, futures, index, scheduler, worker_wait_s)
            finally:
                client.cancel([f for f in futures if not f.done()])


def _dask_results(distributed: Any, client: Any, futures: list, index: dict, scheduler: str,
                  worker_wait_s: float) -> Iterator[tuple[int, Any]]:
    """The futures' results as they finish, each wait bounded."""
    pending = list(futures)
    workers_seen = time.monotonic()
    while pending:
        done = [future for future in pending if future.done()]
        if done:
            finished = {id(future) for future in done}
            pending = [future for future in pending if id(future) not in finished]
        for future in done:
            yield index[future.key], _dask_result(distributed, future, scheduler)
        if client.status not in ("running", "connecting"):
            raise ParallelFault(f"the Dask scheduler at {scheduler} died or is unreachable: the connection to it was lost")
        if client.scheduler_info().get("workers"):
            workers_seen = time.monotonic()
        elif time.monotonic() - workers_seen > worker_wait_s:
            raise ParallelFault(f"no Dask worker is connected to the scheduler at {scheduler} (for {worker_wait_s:g} s): "
                                "the workers died, or none was started")
        if not done:
            time.sleep(POLL_S)


def _dask_result(distributed: Any, future: Any, scheduler: str) -> Any:
    """One future's result; a cluster fault as a ParallelFault, an item's own CalibPinError as it is."""
    try:
        return future.result()
    except CalibPinError:
        raise
    except distributed.KilledWorker as e:
        tries = re.search(r"on (\d+) different workers", str(e))
        raise ParallelFault(f"Dask workers of the scheduler at {scheduler} died running a task: it was tried on "
                            f"{tries.group(1) if tries else 'several'} workers and each died (killed, out of memory "
                            "or crashed; the worker logs say why)") from None
    except Exception as e:  # noqa: BLE001 - a cluster's failure is one line, not a traceback
        if future.status == "cancelled":
            raise ParallelFault(f"the Dask scheduler at {scheduler} died or is unreachable: "
                                f"the connection to it was lost ({error_line(e)})") from None
        raise ParallelFault(
            f"the Dask cluster at {scheduler} could not run the tasks ({error_line(e)}): the scheduler and every "
            "worker must import the same calib-pin as this process"
        ) from None


def _check_scheduler(scheduler: str) -> None:
    """Refuse a malformed address, an address nothing listens on, and a server that is no Dask scheduler.

    Each in bounded time (:data:`CONNECT_TIMEOUT_S`, :data:`ANSWER_TIMEOUT_S`).
    """
    from distributed.comm import connect
    from distributed.comm.addressing import get_address_host_port, parse_address

    try:  # a malformed address would otherwise fail inside Client and leave it hanging 20 s
        host, port = get_address_host_port(scheduler)
    except ValueError as e:
        raise CalibPinError(f"'{scheduler}' is not a Dask scheduler address ({e}); give tcp://host:port") from None
    try:
        socket.create_connection((host, port), timeout=CONNECT_TIMEOUT_S).close()
    except OSError as e:
        raise ParallelFault(f"cannot reach the Dask scheduler at {scheduler}: "
                            f"{e.strerror or error_line(e)} (is it running?)") from None
    if parse_address(scheduler)[0] != "tcp":
        return  # tls and others need the security settings the Client reads; it checks them

    async def identity() -> Any:
        comm = await connect(scheduler, timeout=CONNECT_TIMEOUT_S)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    def ask() -> Any:  # in a thread of its own: the caller may run an event loop already (Jupyter)
        return asyncio.run(asyncio.wait_for(identity(), ANSWER_TIMEOUT_S))

    try:
        with _quiet_dask_logs(), ThreadPoolExecutor(1) as pool:
            answer = pool.submit(ask).result()
    except TimeoutError:
        raise ParallelFault(f"{scheduler} is not a Dask scheduler: it accepts connections but gave no Dask answer "
                            f"within {ANSWER_TIMEOUT_S:g} s") from None
    except Exception as e:  # noqa: BLE001 - whatever the server sent, it is not a scheduler
        raise ParallelFault(f"{scheduler} is not a Dask scheduler: its answer is not Dask's ({error_line(e)})") from None
    if not isinstance(answer, dict) or answer.get("type") != "Scheduler":
        kind = answer.get("type") if isinstance(answer, dict) else type(answer).__name__
        raise ParallelFault(f"{scheduler} is not a Dask scheduler: it answers as {kind}")


@contextlib.contextmanager
def _quiet_dask_logs() -> Iterator[None]:
    """Within this block distributed logs nothing: its faults become one line here."""
    names = ["distributed", *(n for n in logging.root.manager.loggerDict if n.startswith("distributed."))]
    loggers = [logging.getLogger(n) for n in names]
    levels = [logger.level for logger in loggers]
    for logger in loggers:
        logger.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for logger, level in zip(loggers, levels, strict=True):
            logger.setLevel(level)
