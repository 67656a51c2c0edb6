"""Sweeps of independent, seeded points on any ``concurrent.futures.Executor``.

A sweep is a task (a module-level function, so it pickles by reference) and a list of points,
each a plain dict of numbers, strings, lists and dicts (JSON data). A point is identified by its
key, a hash of its parameters, so the same point always has the same key. Points run on

* a process pool (default; ``max_workers`` processes),
* in this process, one after the other (``max_workers=1``: the serial reference),
* or any executor the caller passes: ``dask.distributed.Client(...).get_executor()``,
  ``mpi4py.futures.MPIPoolExecutor()``, a thread pool, ...

Each finished point is appended to the output file as one JSON line and flushed at once; a
point that raised is recorded with its error and the sweep goes on. Rerunning a sweep on the
same file skips the points already recorded, so an interrupted sweep resumes where it stopped.
Progress goes to stderr.

Workers never receive sympy objects: the caller generates the code a point needs in the parent
(``pulsemap.solvers.models.codeload``) and puts :func:`generated_ref` of each module into the point; the worker
loads it by name with :func:`load_generated`, which checks the source hash.
"""

from __future__ import annotations

import concurrent.futures as cf
import hashlib
import json
import math
import os
import socket
import sys
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any, Callable, Iterable, Mapping, TextIO

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.data.numba_cache import call_recovering_numba_cache
from pulsemap.solvers.data.records import open_for_append, read_keyed, write_record
from pulsemap.solvers.studies.progress import Progress, StatusLine, describe

__all__ = [
    "SweepError",
    "SweepResult",
    "generated_ref",
    "load_generated",
    "point_key",
    "read_records",
    "run_sweep",
]

KEY_LENGTH = 16
FORMAT = 1  # record layout version, part of every record
LOST = "lost"  # status of a point the executor lost (a worker died): retried by every rerun


class SweepError(PulsemapError):
    """A sweep that cannot run as asked (bad points, bad output file, missing generated code)."""


# ----------------------------------------------------------------------------- keys


def _plain(value: Any, where: str = "point") -> Any:
    """``value`` as JSON data (dict/list/str/int/float/bool/None), or a SweepError."""
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, int):
        return int(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise SweepError(f"{where} = {value!r} is not finite: sweep parameters must be finite numbers")
        return float(value)
    if hasattr(value, "item") and getattr(value, "ndim", None) == 0:  # numpy scalar
        return _plain(value.item(), where)
    if isinstance(value, Mapping):
        out = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise SweepError(f"{where} has a non-string key {k!r}: use string keys")
            out[k] = _plain(v, f"{where}.{k}")
        return out
    if isinstance(value, (list, tuple)) or hasattr(value, "tolist"):
        items = value.tolist() if hasattr(value, "tolist") else value
        return [_plain(v, f"{where}[{j}]") for j, v in enumerate(items)]
    raise SweepError(
        f"{where} is a {type(value).__name__}: sweep points hold only numbers, strings, lists and dicts"
    )


def canonical(params: Mapping[str, Any]) -> str:
    """The canonical JSON text of a point (sorted keys, no spaces): what its key hashes."""
    return json.dumps(_plain(params), sort_keys=True, separators=(",", ":"))


def point_key(params: Mapping[str, Any]) -> str:
    """Stable key of a point: the first 16 hex digits of sha256 of its canonical JSON."""
    return hashlib.sha256(canonical(params).encode()).hexdigest()[:KEY_LENGTH]


# ----------------------------------------------------------------------------- generated code


def generated_ref(module: ModuleType) -> dict:
    """``{"name", "hash"}`` of a loaded generated module: what a worker needs to load it."""
    from pulsemap.symbolic.sources import module_name, source_from_dict, source_hash

    source = source_from_dict(module.SOURCE)
    return {"name": module_name(source), "hash": source_hash(source)}


def load_generated(ref: Mapping[str, str]) -> ModuleType:
    """Load a generated module by name (generated/ or the cache) and check its source hash."""
    from pulsemap.symbolic.sources import source_from_dict, source_hash
    from pulsemap.solvers.models.codeload import load_by_name

    try:
        module = load_by_name(ref["name"])
    except FileNotFoundError:
        raise SweepError(
            f"generated module {ref['name']} is not on this worker: share PULSEMAP_CACHE_DIR with the "
            "workers or run 'pulsemap generate' where they run"
        ) from None
    got = source_hash(source_from_dict(module.SOURCE))
    if got != ref["hash"]:
        raise SweepError(
            f"generated module {ref['name']} has source hash {got[:16]}..., the sweep expects "
            f"{ref['hash'][:16]}...: regenerate it ('pulsemap generate') on the workers"
        )
    return module


# ----------------------------------------------------------------------------- records


STATUSES = ("ok", "error", LOST)


def check_record(rec: Mapping[str, Any]) -> str | None:
    """What makes ``rec`` no record of ours (the layout :func:`_record` writes), or None."""
    if rec.get("format") != FORMAT:
        return f"format {rec.get('format')!r}, not {FORMAT}"
    for field, kind in (("key", str), ("task", str), ("params", dict), ("status", str)):
        if not isinstance(rec.get(field), kind):
            return f"'{field}' is {type(rec.get(field)).__name__}, not {kind.__name__}"
    if rec["status"] not in STATUSES:
        return f"status {rec['status']!r} is none of {', '.join(STATUSES)}"
    if rec["status"] == "ok" and not isinstance(rec.get("result"), dict):
        return "a finished point without a result"
    if rec["status"] != "ok" and not isinstance(rec.get("error"), str):
        return "a failed point without an error message"
    return None  # a key that is not the hash of its params is run_sweep's "use a fresh output file"


def read_records(path: str | Path) -> dict[str, dict]:
    """Records of an output file by key (the last record of a key wins).

    A line that is not complete JSON (the sweep was killed while writing it) is ignored; a
    record that is not of our layout or holds a NaN is ignored with a note naming file and line
    (its point is run again).
    """
    return read_keyed(path, check=check_record)


def _call(task: Callable[[dict], dict], params: dict) -> dict:
    """Run one point in a worker; an exception becomes an error record (the sweep goes on)."""
    t0 = time.perf_counter()
    where = {"host": socket.gethostname(), "pid": os.getpid()}
    try:
        result = call_recovering_numba_cache(task, params)  # numba's damaged cache files: removed, run again
    except Exception as exc:  # noqa: BLE001 - recorded with its message, the sweep goes on
        message = str(exc).splitlines()[0] if str(exc) else ""
        return {"status": "error", "error": f"{type(exc).__name__}: {message}".rstrip(": "),
                "elapsed_s": time.perf_counter() - t0, **where}
    return {"status": "ok", "result": result, "elapsed_s": time.perf_counter() - t0, **where}


def _exit_with_parent(poll_s: float = 0.5) -> None:
    """Process-pool initializer: the worker exits when its parent dies (e.g. a killed sweep),
    instead of waiting forever for work that will never come."""
    parent = os.getppid()

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(poll_s)
        os._exit(1)

    threading.Thread(target=watch, name="pulsemap-parent-watch", daemon=True).start()


def _record(key: str, params: dict, task_name: str, outcome: dict) -> dict:
    rec = {"format": FORMAT, "key": key, "task": task_name, "params": params, "status": outcome["status"]}
    if outcome["status"] == "ok":
        rec["result"] = _plain(outcome["result"], "result")
    else:
        rec["error"] = outcome["error"]
    rec.update({k: outcome[k] for k in ("elapsed_s", "host", "pid") if k in outcome})
    rec["finished_unix"] = time.time()
    return rec


# ----------------------------------------------------------------------------- the sweep


@dataclass(frozen=True)
class SweepResult:
    """The records of a sweep's points, in the order the points were given."""

    records: list[dict]
    computed: int  # points run by this call
    skipped: int  # points found already recorded in the output file
    failed: int  # points recorded with an error (this call or earlier)
    wall_s: float
    executor: str
    out: str | None = None

    def results(self) -> list[dict | None]:
        """The result of each point (None where it failed)."""
        return [r.get("result") if r["status"] == "ok" else None for r in self.records]

    def summary(self) -> dict:
        return {"points": len(self.records), "computed": self.computed, "skipped": self.skipped,
                "failed": self.failed, "wall_s": self.wall_s, "executor": self.executor, "out": self.out}


def worker_count(asked: int | None, stream: TextIO | None = None) -> int | None:
    """Processes of the sweep's own pool: ``asked`` capped at the machine's CPU count (more only share
    the same cores, and each holds its own copy of the chain), with a note on ``stream`` when capped."""
    cpus = os.cpu_count() or 1
    if asked is None or asked <= cpus:
        return asked
    print(f"pulsemap: note: {asked} workers asked, this machine has {cpus} CPUs: running {cpus}",
          file=stream if stream is not None else sys.stderr, flush=True)
    return cpus


def _task_name(task: Callable) -> str:
    return f"{getattr(task, '__module__', '?')}.{getattr(task, '__qualname__', repr(task))}"


def run_sweep(
    task: Callable[[dict], dict],
    points: Iterable[Mapping[str, Any]],
    out: str | Path | None = None,
    *,
    executor: cf.Executor | None = None,
    max_workers: int | None = None,
    progress: bool = False,
    retry_failed: bool = False,
    label: str = "sweep",
    stream: TextIO | None = None,
    name_of: Callable[[dict], str] | None = None,
) -> SweepResult:
    """Run ``task(params)`` for every point; record each as it finishes; skip recorded points.

    ``out``: the JSON-lines file (one record per point: key, task, params, status, result or
    error, elapsed time, host, pid); points already in it are not run again (``retry_failed``
    reruns the ones recorded with an error; points the executor lost are always rerun). ``executor``: any concurrent.futures.Executor (it
    is not shut down here); otherwise a ProcessPoolExecutor of ``max_workers`` processes
    (default: the CPU count), or this process alone when ``max_workers == 1``. Progress names
    each point by ``name_of(point)``, by default by the values that vary across the points.
    """
    if max_workers is not None and (isinstance(max_workers, bool) or not isinstance(max_workers, int) or max_workers < 1):
        raise SweepError(f"max_workers must be an integer >= 1, got {max_workers!r}")
    if executor is not None and not isinstance(executor, cf.Executor) and not hasattr(executor, "submit"):
        raise SweepError(f"executor must be a concurrent.futures.Executor, got {type(executor).__name__}")
    err = stream if stream is not None else sys.stderr
    if executor is None:
        max_workers = worker_count(max_workers, err)
    t_start = time.perf_counter()
    task_name = _task_name(task)
    todo: dict[str, dict] = {}
    order: list[str] = []
    for j, p in enumerate(points):
        if not isinstance(p, Mapping):
            raise SweepError(f"point {j} is a {type(p).__name__}: a point is a dict of parameters")
        params = _plain(p, f"point {j}")
        key = point_key(params)
        if key not in todo:
            todo[key] = params
            order.append(key)
    path = Path(out) if out is not None else None
    done = read_records(path) if path is not None else {}
    for key in order:
        rec = done.get(key)
        if rec is not None and rec.get("params") != todo[key]:
            raise SweepError(f"{path}: record {key} holds other parameters than the point with that key: "
                             "use a fresh output file")
    pending = [k for k in order if k not in done or done[k].get("status") == LOST
               or (retry_failed and done[k].get("status") != "ok")]
    skipped = len(order) - len(pending)
    records: dict[str, dict] = {k: done[k] for k in order if k in done}
    if progress:
        print(f"[{label}] {len(order)} points: {skipped} already recorded"
              f"{' in ' + str(path) if path is not None and skipped else ''}, {len(pending)} to run", file=err)

    fh = open_for_append(path) if path is not None and pending else None
    computed = 0
    report = Progress(label, len(pending), enabled=progress, screen=StatusLine(err))
    if not progress:
        names = {}
    elif name_of is not None:
        names = {k: name_of(todo[k]) for k in order}
    else:
        names = dict(zip(order, describe([todo[k] for k in order])))

    def finish(key: str, outcome: dict) -> None:
        nonlocal computed
        rec = _record(key, todo[key], task_name, outcome)
        records[key] = rec
        computed += 1
        if fh is not None:
            write_record(fh, rec)
        what = "ok" if rec["status"] == "ok" else "FAILED: " + rec["error"]
        report.finish(names.get(key, key), what, rec.get("elapsed_s"))

    own = None
    try:
        if executor is None and (max_workers == 1 or not pending):
            kind = "serial"
            for key in pending:
                finish(key, _call(task, todo[key]))
        else:
            if executor is None:
                own = cf.ProcessPoolExecutor(max_workers=max_workers, initializer=_exit_with_parent)
                kind = f"process pool ({max_workers or os.cpu_count()} workers)"
                ex = own
            else:
                ex = executor
                kind = type(executor).__name__
            limit = max(2 * (max_workers or os.cpu_count() or 1), 4) if executor is None else len(pending)
            queue = list(pending)
            running: dict[cf.Future, str] = {}
            while queue or running:
                while queue and len(running) < limit:
                    key = queue.pop(0)
                    running[ex.submit(_call, task, todo[key])] = key
                ready, _ = cf.wait(list(running), return_when=cf.FIRST_COMPLETED)
                for fut in ready:
                    key = running.pop(fut)
                    try:
                        outcome = fut.result()
                    except Exception as exc:  # noqa: BLE001 - the executor lost the point (worker died)
                        text = f"{type(exc).__name__}: {exc}".splitlines()[0]
                        outcome = {"status": LOST, "error": f"executor lost the point ({text}); a rerun retries it"}
                    finish(key, outcome)
    finally:
        if fh is not None:
            fh.close()
        if own is not None:
            own.shutdown(wait=True, cancel_futures=True)
    ordered = [records[k] for k in order]
    failed = sum(1 for r in ordered if r["status"] != "ok")
    result = SweepResult(ordered, computed, skipped, failed, time.perf_counter() - t_start, kind,
                         None if path is None else str(path))
    if progress:
        print(f"[{label}] done: {computed} run, {skipped} skipped, {failed} failed, "
              f"{result.wall_s:.1f} s ({kind})", file=err)
    return result
