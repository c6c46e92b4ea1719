"""Sweeps: many trials over seeds and configurations, on local processes or Ray (layer 5).

A sweep is a list of runs (kind, configuration, seed). The runs not yet in the trial
database go to an executor: a pool of local processes (the default) or a Ray cluster
(`ray start --head` on one machine is enough). The executor only runs them; the
database, written by this process as each run ends, is the record. A worker that dies
(killed, out of memory, a lost Ray node) loses only the runs it was carrying: they are
started again, up to `max_attempts` times, then stored with the error. An interrupted
sweep (Ctrl+C) keeps every finished run; starting it again with `resume` runs the rest.
"""

from __future__ import annotations

import itertools
import os
import socket
import time
import traceback
from collections.abc import Callable, Iterable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Any

from robotrial.trials.kinds import trial_kind
from robotrial.trials.store import RunRecord, RunSpec, TrialStore


def grid(kind: str, settings: dict[str, list[Any]], seeds: Iterable[int]) -> list[RunSpec]:
    """Every combination of the settings' values, each with every seed."""
    k = trial_kind(kind)
    names = list(settings)
    specs = []
    for values in itertools.product(*(settings[n] for n in names)):
        config = k.config(dict(zip(names, values, strict=True)))
        specs.extend(RunSpec(kind, config, int(s)) for s in seeds)
    return specs


def execute(kind: str, config: dict[str, Any], seed: int, out: str) -> dict[str, Any]:
    """Run one trial where this is called (a worker); an exception inside the trial is
    its result (the run is stored with it), not a reason to run it again."""
    t0 = time.perf_counter()
    worker = f"{socket.gethostname()}:{os.getpid()}"
    try:
        o = trial_kind(kind).run(config, seed, Path(out))
    except Exception as exc:
        frames = traceback.extract_tb(exc.__traceback__)
        ours = [f for f in frames if "robotrial" in Path(f.filename).parts] or frames
        where = f"{Path(ours[-1].filename).name}:{ours[-1].lineno}"
        return {
            "success": False,
            "error": f"{type(exc).__name__}: {exc} ({where})",
            "figures": {},
            "files": {},
            "worker": worker,
            "wall_time": time.perf_counter() - t0,
        }
    return {
        "success": o.success,
        "error": None,
        "figures": o.figures,
        "files": o.files,
        "worker": worker,
        "wall_time": time.perf_counter() - t0,
    }


class WorkerLost(Exception):
    """The process or node running a trial went away before answering."""


class LocalExecutor:
    """Trials in `workers` local processes (spawned: no state shared with this one).
    A dead worker breaks the pool: every run in it is lost and the pool starts anew."""

    def __init__(self, workers: int) -> None:
        if workers < 1:
            raise ValueError(f"--workers must be at least 1, got {workers}")
        self.workers = workers
        self._pool: ProcessPoolExecutor | None = None
        self._pool_of: dict[Future, ProcessPoolExecutor] = {}

    def submit(self, spec: RunSpec, out: str) -> Future:
        if self._pool is not None:
            try:
                return self._submit(spec, out)
            except BrokenProcessPool:  # a worker died since the last answer was read
                self.close()
        self._pool = ProcessPoolExecutor(self.workers, mp_context=get_context("spawn"))
        return self._submit(spec, out)

    def _submit(self, spec: RunSpec, out: str) -> Future:
        assert self._pool is not None
        handle = self._pool.submit(execute, spec.kind, spec.config, spec.seed, out)
        self._pool_of[handle] = self._pool
        return handle

    def wait(self, handles: list[Future]) -> list[Future]:
        done, _ = wait(handles, return_when=FIRST_COMPLETED)
        return list(done)

    def result(self, handle: Future) -> dict[str, Any]:
        pool = self._pool_of.pop(handle)
        try:
            return handle.result()
        except BrokenProcessPool as exc:
            if pool is self._pool:
                self.close()
            raise WorkerLost("a worker process died") from exc

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=False, cancel_futures=True)
            self._pool = None


class RayExecutor:
    """Trials as Ray tasks on the cluster at `address` ("local": start one here). Ray
    does not retry them itself, so that every start is counted here."""

    def __init__(self, address: str, workers: int | None = None) -> None:
        try:
            import ray
        except ImportError as exc:
            raise ValueError("--ray needs Ray: pip install 'ray>=2.9'") from exc
        self._ray = ray
        if not ray.is_initialized():
            kwargs: dict[str, Any] = {
                "include_dashboard": False,
                "log_to_driver": False,
                "configure_logging": False,
            }
            if address == "local":
                kwargs["num_cpus"] = workers or os.cpu_count()
            else:
                kwargs["address"] = address
            try:
                ray.init(**kwargs)
            except (ConnectionError, RuntimeError, ValueError) as exc:
                raise ValueError(f"--ray {address}: cannot reach the cluster ({exc})") from exc
        self._remote = ray.remote(max_retries=0)(execute)
        self.workers = workers or max(1, int(ray.cluster_resources().get("CPU", 1)))

    def submit(self, spec: RunSpec, out: str) -> Any:
        return self._remote.remote(spec.kind, spec.config, spec.seed, out)

    def wait(self, handles: list[Any]) -> list[Any]:
        done, _ = self._ray.wait(handles, num_returns=1)
        return done

    def result(self, handle: Any) -> dict[str, Any]:
        ex = self._ray.exceptions
        try:
            return self._ray.get(handle)
        except (ex.WorkerCrashedError, ex.NodeDiedError, ex.OwnerDiedError) as exc:
            raise WorkerLost(str(exc).splitlines()[0]) from exc

    def close(self) -> None:
        self._ray.shutdown()


@dataclass
class SweepResult:
    """How a sweep went: runs asked for, already in the database, run now, starts lost to
    dead workers, and whether it was interrupted before the end."""

    total: int
    skipped: int
    finished: int
    lost: int
    interrupted: bool = False


class AlreadyRun(ValueError):
    """The database already holds runs of this sweep and `resume` was not asked for."""


def run_sweep(
    specs: list[RunSpec],
    store: TrialStore,
    executor: LocalExecutor | RayExecutor,
    sweep: str,
    out: str | Path,
    resume: bool = False,
    max_attempts: int = 3,
    on_record: Callable[[RunRecord], None] | None = None,
) -> SweepResult:
    """Run every spec not yet in `store`, at most `executor.workers` at a time, storing
    each as it ends; `on_record` hears of each stored run."""
    unique = list({s.key: s for s in specs}.values())
    done = store.done_keys([s.key for s in unique])
    if done and not resume:
        raise AlreadyRun(
            f"{store.path} already holds {len(done)} of these {len(unique)} runs; "
            "add --resume to run the rest, or choose another database"
        )
    todo = [s for s in unique if s.key not in done]
    result = SweepResult(len(unique), len(done), 0, 0)
    attempts: dict[str, int] = {}
    flying: dict[Any, RunSpec] = {}
    out = str(Path(out).resolve())

    def launch() -> None:
        while todo and len(flying) < executor.workers:
            spec = todo.pop(0)
            attempts[spec.key] = attempts.get(spec.key, 0) + 1
            flying[executor.submit(spec, str(Path(out) / spec.key))] = spec

    def store_run(spec: RunSpec, res: dict[str, Any]) -> None:
        rec = RunRecord(
            spec,
            sweep,
            res["success"],
            res["error"],
            res["figures"],
            res["files"],
            res["worker"],
            attempts[spec.key],
            res["wall_time"],
        )
        if store.add(rec):
            result.finished += 1
            if on_record is not None:
                on_record(rec)

    try:
        launch()
        while flying:
            for handle in executor.wait(list(flying)):
                spec = flying.pop(handle)
                try:
                    res = executor.result(handle)
                except WorkerLost as exc:
                    result.lost += 1
                    if attempts[spec.key] >= max_attempts:
                        store_run(spec, _lost(exc, attempts[spec.key]))
                    else:
                        todo.insert(0, spec)
                    continue
                store_run(spec, res)
            launch()
    except KeyboardInterrupt:
        result.interrupted = True
    finally:
        executor.close()
    return result


def _lost(exc: WorkerLost, attempts: int) -> dict[str, Any]:
    return {
        "success": False,
        "error": f"the worker died under this run {attempts} times ({exc})",
        "figures": {},
        "files": {},
        "worker": "",
        "wall_time": 0.0,
    }
