"""Execution backends. Each takes batches of run numbers and yields lists of run records as
batches finish (in any order); the caller checkpoints and assembles them.

* `run_inline`: in this process, one batch after another (debugging, notebooks, lambdas).
* `run_pool`: a local ProcessPoolExecutor (spawn, one BLAS thread per worker); every worker
  loads the module and the run config once. A worker that dies (killed, out of memory,
  crash) breaks the pool:
  the runs that were in flight are retried one at a time in a fresh pool, and a run that kills
  its worker when running alone is recorded as failed.
* `run_dask`: an existing Dask cluster (address or Client); batches are tasks, the module file's
  bytes are broadcast once and workers that cannot see the file import a cached copy.
"""

from __future__ import annotations

import collections
import contextlib
import math
import multiprocessing
import os
import pickle
import sys
import types
from collections.abc import Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool

import numpy as np

from .worker import ModuleRef, RunConfig, init_pool_worker, pool_run_batch, run_batch

__all__ = ["StudyError", "default_workers", "split_batches", "guided_batches", "run_inline",
           "run_pool",
           "run_dask", "DIED"]

CONNECT_TIMEOUT = "20s"
DIED = "worker process died while running this run (killed, out of memory or crashed)"


class StudyError(RuntimeError):
    """The study cannot go on (workers cannot load the module, the Dask scheduler cannot be
    reached). Finished runs are kept in the checkpoint; fix the cause and resume."""


def default_workers() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def split_batches(indices: Sequence[int], size: int) -> list[list[int]]:
    indices = list(indices)
    return [indices[i:i + size] for i in range(0, len(indices), size)]


def guided_batches(indices: Sequence[int], slots: int, cap: int) -> list[list[int]]:
    """Batches that shrink as the runs left do (guided scheduling): each holds the runs left
    shared by twice the slots (the pool keeps two batches a slot in flight), at most `cap`
    and at least one run. The first batches are `cap` long; the last are single runs, so
    the workers finish within a run of each other instead of one waiting out another's
    last batch of `cap` runs."""
    indices, out, first = list(indices), [], 0
    while first < len(indices):
        size = max(1, min(cap, math.ceil((len(indices) - first) / (2 * max(1, slots)))))
        out.append(indices[first:first + size])
        first += size
    return out


def batch_size_for(todo: int, slots: int, per_slot: int, cap: int) -> int:
    """Enough batches to balance the load (`per_slot` per worker slot), at most `cap` runs."""
    return max(1, min(cap, math.ceil(todo / max(1, slots * per_slot))))


def _failed(index: int, message: str) -> dict:
    return {"run": int(index), "failed": True, "error": message, "values": {},
            "wall": math.nan, "series": None}


def _dumps(config: RunConfig) -> bytes:
    """Pickle the run config for the pool's workers. They do not run the parent's `__main__`
    (`_Context`), so a metric or simulate function defined there goes by value, with
    cloudpickle (which ships with dask), as do lambdas and local functions."""
    if not _from_main(config):
        try:
            return pickle.dumps(config)
        except (pickle.PicklingError, AttributeError, TypeError):
            pass
    try:
        import cloudpickle
    except ImportError:
        raise StudyError("metrics and simulate must be module-level functions of an "
                         "importable module for the process pool; install cloudpickle or "
                         "use scheduler='inline'") from None
    return cloudpickle.dumps(config)


def _from_main(config: RunConfig) -> bool:
    """Whether a function of the config (or its class) is defined in `__main__`."""
    functions = [*(config.metrics or {}).values(), config.simulate]
    return any(getattr(f, "__module__", None) == "__main__"
               or type(f).__module__ == "__main__" for f in functions if f is not None)


def run_inline(ref: ModuleRef, config: RunConfig, matrix: np.ndarray,
               batches: Sequence[Sequence[int]]) -> Iterator[list[dict]]:
    for batch in batches:
        yield run_batch(ref, config, batch, matrix[batch])


# One BLAS/OpenMP thread per worker process (as Dask's nannies do): a run's matrices are small,
# and several processes each spinning several BLAS threads on the same cores ran the INTELSAT
# study 1.5x slower. A variable the user has set is left alone.
SINGLE_THREAD_ENV = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                     "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")


@contextlib.contextmanager
def _worker_environment():
    """Set SINGLE_THREAD_ENV while worker processes start (spawn copies os.environ)."""
    added = [name for name in SINGLE_THREAD_ENV if name not in os.environ]
    for name in added:
        os.environ[name] = "1"
    try:
        yield
    finally:
        for name in added:
            os.environ.pop(name, None)


class _WorkerProcess(multiprocessing.context.SpawnProcess):
    """A spawned worker that does not import the parent's `__main__` again. Spawn imports
    the main script in every child (hence Python's rule that a script starting processes
    guards its work with `if __name__ == "__main__":`); a study's workers need nothing of it
    (the config comes pickled, functions of `__main__` by value: `_dumps`), so a script
    that calls a study without the guard works, and is not run again in each worker."""

    @staticmethod
    def _Popen(process_obj):
        main = sys.modules["__main__"]
        sys.modules["__main__"] = types.ModuleType("__main__")  # no file to import
        try:
            return multiprocessing.context.SpawnProcess._Popen(process_obj)
        finally:
            sys.modules["__main__"] = main


class _Context(multiprocessing.context.SpawnContext):
    Process = _WorkerProcess


def _context():
    # spawn, not forkserver: a fork server started earlier in this process would hand the
    # workers its own environment, not the one set by _worker_environment.
    return _Context()


def _kill(pool: ProcessPoolExecutor) -> None:
    """Stop a pool now: cancel what waits and terminate the workers (they ignore SIGINT)."""
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in procs:
        try:
            proc.terminate()
        except Exception:
            pass
    for proc in procs:
        try:
            proc.join(timeout=5)
        except Exception:
            pass


def run_pool(ref: ModuleRef, config: RunConfig, matrix: np.ndarray,
             batches: Sequence[Sequence[int]], workers: int) -> Iterator[list[dict]]:
    blob = _dumps(config)
    workers = max(1, min(workers, len(batches)))
    queue = collections.deque(list(b) for b in batches)
    quarantine: collections.deque[int] = collections.deque()
    consecutive_deaths = 0
    any_success = False
    died: list[dict] = []  # runs that killed their worker, held until a run succeeds

    def new_pool() -> ProcessPoolExecutor:
        return ProcessPoolExecutor(workers, mp_context=_context(), initializer=init_pool_worker,
                                   initargs=(ref, blob))

    environment = _worker_environment()
    environment.__enter__()
    pool = new_pool()
    inflight: dict = {}
    try:
        while queue or quarantine or inflight:
            if quarantine:
                if not inflight:
                    index = quarantine.popleft()
                    inflight[pool.submit(pool_run_batch, [index], matrix[[index]])] = [index]
            else:
                while queue and len(inflight) < 2 * workers:
                    batch = queue.popleft()
                    inflight[pool.submit(pool_run_batch, batch, matrix[batch])] = batch
            alone = len(inflight) == 1 and len(next(iter(inflight.values()))) == 1
            done, _ = wait(list(inflight), return_when=FIRST_COMPLETED)
            broken: list[list[int]] = []
            for future in done:
                batch = inflight.pop(future)
                try:
                    records = future.result()
                except BrokenProcessPool:
                    broken.append(batch)
                else:
                    consecutive_deaths, any_success = 0, True
                    if died:
                        yield died
                        died = []
                    yield records
            if not broken:
                continue
            # Every other future of a broken pool fails too, except those already finished.
            for future, batch in list(inflight.items()):
                try:
                    records = future.result()
                except BrokenProcessPool:
                    broken.append(batch)
                except Exception:
                    broken.append(batch)
                else:
                    any_success = True
                    yield records
            inflight.clear()
            _kill(pool)
            if alone and len(broken) == 1 and len(broken[0]) == 1:
                consecutive_deaths += 1
                died.append(_failed(broken[0][0], DIED))
                if any_success:
                    yield died
                    died = []
                elif consecutive_deaths >= 3:  # nothing ever worked: not the runs' fault
                    raise StudyError("worker processes die at start-up or on every run; "
                                     "check that the generated module imports in a fresh "
                                     "Python process")
            else:
                quarantine.extend(i for batch in broken for i in batch)
            pool = new_pool()
        if died:
            yield died
    finally:
        _kill(pool)
        environment.__exit__(None, None, None)


def run_dask(ref: ModuleRef, config: RunConfig, matrix: np.ndarray,
             batches: Sequence[Sequence[int]], scheduler) -> Iterator[list[dict]]:
    try:
        from distributed import Client, as_completed
        from distributed.scheduler import KilledWorker
    except ImportError:
        raise StudyError("a Dask scheduler needs dask[distributed]: "
                         "pip install 'depsim[studies]'") from None
    own = not isinstance(scheduler, Client)
    if own:
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT)
        except (OSError, TimeoutError, ValueError) as exc:
            raise StudyError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None
    else:
        client = scheduler
    futures: dict = {}
    try:
        ref_data = client.scatter(ref.with_source(), broadcast=True, hash=False)
        config_data = client.scatter(config, broadcast=True, hash=False)

        def submit(batch: list[int]):
            future = client.submit(run_batch, ref_data, config_data, batch, matrix[batch],
                                   pure=False)
            futures[future] = batch
            return future

        pending = as_completed([submit(list(b)) for b in batches])
        for future in pending:
            batch = futures.pop(future)
            try:
                records = future.result()
            except KilledWorker:
                if len(batch) == 1:
                    yield [_failed(batch[0], DIED)]
                else:
                    for index in batch:
                        pending.add(submit([index]))
                continue
            except (ImportError, FileNotFoundError, RuntimeError, OSError) as exc:
                raise StudyError(f"a Dask worker could not run the study: "
                                 f"{type(exc).__name__}: {exc}") from exc
            yield records
    finally:
        if futures:
            try:
                client.cancel(list(futures))
            except Exception:
                pass
        if own:
            client.close()
