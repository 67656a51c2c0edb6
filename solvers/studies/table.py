"""The ranking table: every reduced model against the DNS for every paper scene (``pulsemap table``).

One DNS per scene (the reference), then every model column seeded from the same DNS peak at
contact first_perturbed - 1: the paper's map (exact and Pade profile; variants corrected and 1d),
the long-wave law (both profiles), and the energy- and momentum-balance maps and laws
(derive/balance.py), and the relaxed map (models/relaxed.py). Errors are every output's
(studies/errors.py: percent over the live range, contacts first_perturbed up to the last whose
DNS peak is >= 2 % of the seed peak; a model that has ended there counts 100 %). The winner of a
scene is the model with the least RMS of that error.

Each scene's row is appended to a JSON-lines file as soon as it is finished; a rerun skips the
scenes whose row is there with the same key (scene, columns, table version), so an interrupted
table loses nothing.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from dataclasses import dataclass
from pathlib import Path

from pulsemap.symbolic.errors import PulsemapError
from pulsemap.solvers.data.scene.overrides import with_sets
from pulsemap.solvers.data.records import append_record, read_keyed
from pulsemap.solvers.studies.progress import Progress
from pulsemap.solvers.studies.workers import cores, fork_pool
from pulsemap.solvers.studies.run import derive_while_kernels_build, run_scene
from pulsemap.solvers.data.scene import builtin_scenes, load_scene, with_overrides

#: Bump when what a row holds or how it is computed changes (old rows are then recomputed).
TABLE_VERSION = 4
DEFAULT_ROWS_FILE = "pulsemap-table.jsonl"


@dataclass(frozen=True)
class Column:
    """One model of the ranking: a run_scene method with its profile and map variant."""

    method: str
    profile: str = "exact"
    variant: str = "paper"

    @property
    def key(self) -> str:
        if self.method == "map":
            return f"map/{self.profile}/{self.variant}"
        return f"{self.method}/{self.profile}"


COLUMNS = (
    Column("map", "exact", "paper"),
    Column("map", "pade", "paper"),
    Column("map", "exact", "corrected"),
    Column("map", "exact", "1d"),
    Column("longwave", "exact"),
    Column("longwave", "pade"),
    Column("energy-map", "exact"),
    Column("energy-law", "exact"),
    Column("momentum-map", "exact"),
    Column("momentum-law", "exact"),
    Column("relaxed", "exact"),
    Column("dressed-law", "exact"),
)


class TableError(PulsemapError):
    """A rows file that cannot be used."""


def row_key(scene_data: dict, columns=COLUMNS) -> str:
    """What a row depends on: the resolved scene, the columns and the table version."""
    text = json.dumps({"scene": scene_data, "columns": [c.key for c in columns], "version": TABLE_VERSION},
                      sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:20]


def winner(errors: dict) -> tuple[str | None, float | None, str | None, float | None]:
    """(best key, its RMS %, runner-up key, its RMS %) by the RMS error (studies/errors.py)."""
    scored = sorted((e["rms_pct"], k) for k, e in errors.items() if e is not None and e.get("rms_pct") is not None)
    if not scored:
        return None, None, None, None
    best = scored[0]
    second = scored[1] if len(scored) > 1 else (None, None)
    return best[1], best[0], second[1], second[0]


def _scene(name: str, eps: float | None, sets: tuple = ()):
    scene = with_sets(load_scene(name), sets)
    return scene if eps is None else with_overrides(scene, eps=eps)


def scene_row(name: str, progress: bool = False, columns=COLUMNS, eps: float | None = None,
              sets: tuple = (), scene=None) -> dict:
    """Errors of every column for one scene (one DNS, reused by every model); ``eps`` overrides the
    scene's, ``sets`` are --set assignments ('key=value', data/scene/overrides.py); ``scene``: the scene
    already loaded so (else loaded here)."""
    scene = _scene(name, eps, sets) if scene is None else scene
    t0 = time.perf_counter()
    ref = run_scene(scene, methods=["dns"], progress=progress)
    row = {
        "scene": name,
        "key": row_key(scene.as_dict(), columns),
        "R": scene.perturbation.text,
        "eps": scene.perturbation.eps,
        "v0": scene.velocity,
        "live": len(ref["dns"]["live_contacts"]),
        "seed_peak": ref["dns"].get("seed_peak"),
        "dns_s": ref["timings_s"]["dns"],
        "dns_stop": ref["dns"]["stop_reason"],
        "errors": {},
        "notes": {},
        "time_s": {},
    }
    for col in columns:
        res = run_scene(scene, methods=[col.method], profile=col.profile, variant=col.variant, reuse_dns=ref,
                        stated_accuracy=False)  # a row keeps the errors only
        err = res["errors"].get(col.method)
        row["errors"][col.key] = err
        row["time_s"][col.key] = res["timings_s"].get(col.method)
        if err is None:  # refused (undefined for this R) or skipped (site-dependent law)
            why = [w for w in res["warnings"] if w.startswith(col.method) or "skipped" in w]
            row["notes"][col.key] = why[0] if why else "not computed"
    best, best_rms, second, second_rms = winner(row["errors"])
    row["winner"] = {"model": best, "rms_pct": best_rms, "runner_up": second, "runner_up_rms_pct": second_rms}
    row["total_s"] = time.perf_counter() - t0
    return row


def read_rows(path: str | os.PathLike) -> dict[str, dict]:
    """Finished rows of a JSON-lines file by row key (scene, columns and version)."""
    _check_rows_path(path)
    return read_keyed(path, required=("scene",), check=check_row)


def _check_rows_path(path: str | os.PathLike) -> None:
    """A rows file that exists must be a regular file (not a folder, a FIFO or a device like /dev/full)."""
    if Path(path).is_dir():
        raise TableError(f"rows file {path} is a directory: give a file name (e.g. {DEFAULT_ROWS_FILE})")
    if Path(path).exists() and not Path(path).is_file():
        from pulsemap.symbolic.files import kind_of

        raise TableError(f"rows file {path} is {kind_of(os.stat(path).st_mode)}, not a regular file: "
                         f"give a file name (e.g. {DEFAULT_ROWS_FILE})")


def check_row(row: dict) -> str | None:
    """What makes ``row`` no row of ours (the fields :func:`markdown` and :func:`wins` read), or None."""
    for field, kinds in (("scene", str), ("key", str), ("R", str), ("eps", (int, float)), ("v0", (int, float)),
                         ("live", int), ("errors", dict)):
        if not isinstance(row.get(field), kinds) or isinstance(row.get(field), bool):
            return f"'{field}' is missing or of the wrong type"
    def number(v) -> bool:
        return v is None or (isinstance(v, (int, float)) and not isinstance(v, bool))

    for name, err in row["errors"].items():
        if err is None:
            continue
        if not isinstance(err, dict) or not all(number(err.get(k)) for k in ("rms_pct", "max_pct", "compared", "missing")):
            return f"errors of {name!r} are not numbers"
        span = err.get("live_range")
        if span is not None and not (isinstance(span, list) and len(span) == 2 and all(
                isinstance(c, int) and not isinstance(c, bool) for c in span)):
            return f"live range of {name!r} is not two contacts"
    winner = row.get("winner")
    if winner is None:
        return None
    if not isinstance(winner, dict):
        return "'winner' is not a table"
    for field, kinds in (("model", str), ("runner_up", str), ("rms_pct", (int, float)), ("runner_up_rms_pct", (int, float))):
        value = winner.get(field)
        if value is not None and (not isinstance(value, kinds) or isinstance(value, bool)):
            return f"winner '{field}' is of the wrong type"
    if winner.get("model") is not None and winner.get("rms_pct") is None:
        return "a winner without its error"
    return None


def _row(name: str, columns, eps, sets, scene) -> dict:
    return scene_row(name, columns=columns, eps=eps, sets=sets, scene=scene)


def _computed_rows(todo: list[str], scenes: dict, columns, eps, sets, workers: int | None):
    """The rows of ``todo``, in order: computed in ``workers`` forked processes (None: one per core,
    studies/workers.py) when there are two or more, else here, one after the other."""
    count = min(cores() if workers is None else workers, len(todo))
    pool = fork_pool(count) if count >= 2 else None
    if pool is None:
        for name in todo:
            yield _row(name, columns, eps, sets, scenes[name])
        return
    try:
        jobs = [pool.submit(_row, name, columns, eps, sets, scenes[name]) for name in todo]
        for job in jobs:
            yield job.result()
    finally:
        pool.shutdown(cancel_futures=True)


def table(names=None, progress: bool = False, rows_file: str | os.PathLike | None = None,
          fresh: bool = False, columns=COLUMNS, eps: float | None = None, sets: tuple = (),
          workers: int | None = None) -> list[dict]:
    """Rows for ``names`` (default: every built-in scene), reusing finished rows of ``rows_file``.

    ``eps`` runs every scene at that eps instead of its own (e.g. to see which model is right as
    eps -> 0); such rows have their own keys, so they never replace the paper-eps rows. ``workers``:
    processes computing rows (None: one per core; 1: this process alone); the rows are the same.
    """
    if eps is not None and not (isinstance(eps, (int, float)) and 0 < eps < float("inf")):
        raise TableError(f"eps must be a finite number > 0, got {eps!r}")
    if workers is not None and (not isinstance(workers, int) or isinstance(workers, bool) or workers < 1):
        raise TableError(f"workers must be a whole number >= 1 (or None: one per core), got {workers!r}")
    names = list(names or builtin_scenes())
    scenes = {name: _scene(name, eps, sets) for name in names}  # every name and --set checked before any work
    done = read_rows(rows_file) if (rows_file is not None and not fresh) else {}
    if rows_file is not None and fresh and Path(rows_file).exists():
        _check_rows_path(rows_file)  # --fresh never unlinks a device or a FIFO
        Path(rows_file).unlink()
    rows = []
    report = Progress("table", len(names), enabled=progress)
    todo = [n for n in names if (done.get(row_key(scenes[n].as_dict(), columns)) or {}).get("scene") != n]
    derive_while_kernels_build([(scenes[n], [col.method], col.profile, col.variant) for n in todo for col in columns],
                               say=report.say)
    report.started = report.clock()  # the ETA counts the rows, not the kernels' build
    computed = _computed_rows(todo, scenes, columns, eps, sets, workers)
    for name in names:
        old = done.get(row_key(scenes[name].as_dict(), columns))
        if old is not None and old.get("scene") == name:
            report.finish(name, f"already in {rows_file}")
            rows.append(old)
            continue
        report.start(name)
        row = next(computed)
        report.finish(name, "done", row.get("total_s"))
        if rows_file is not None:  # repairs a line cut short first, flushed to disk
            append_record(rows_file, row)
        rows.append(row)
    return rows


def _fmt(err) -> str:
    if err is None or err.get("max_pct") is None:
        return "–"
    return f"{err['max_pct']:.1f} / {err['rms_pct']:.1f}"


def markdown(rows: list[dict], columns=COLUMNS) -> str:
    """The ranking as a markdown table with a winner per scene."""
    keys = [c.key for c in columns]
    head = "| scene | R | eps | v0 | live range | " + " | ".join(keys) + " | winner (RMS %) |"
    sep = "|" + "---|" * (6 + len(keys))
    lines = [
        "Max / RMS relative error (%) against the DNS over the live range: contacts first_perturbed up to the",
        "last whose DNS peak is >= 2 % of the seed peak (a model that has ended there counts as 100 %);",
        "every model seeded with the DNS peak at the last unperturbed contact (n = 3/2, DNS rtol 1e-10:",
        "the compiled RK45 engine where it applies, else scipy). Winner: least RMS; in brackets its margin",
        "over the runner-up. – : undefined (momentum balance with a term without v); a refused model",
        "(e.g. dressed-law outside its range at the seed) counts as 100 %.",
        "",
        head,
        sep,
    ]
    for r in rows:
        span = next((e["live_range"] for e in r["errors"].values() if e is not None and e.get("live_range")), None)
        live = f"{span[0]}..{span[1]}" if span else str(r["live"])
        cells = [r["scene"], f"`{r['R']}`", f"{r['eps']:g}", f"{r['v0']:g}", live]
        cells += [_fmt(r["errors"].get(k)) for k in keys]
        w = r.get("winner") or {}
        if w.get("model"):
            margin = ""
            if w.get("runner_up"):
                margin = f" (vs {w['runner_up']} {w['runner_up_rms_pct']:.1f})"
            cells.append(f"**{w['model']}** {w['rms_pct']:.1f}{margin}")
        else:
            cells.append("–")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def wins(rows: list[dict]) -> dict[str, int]:
    """How many scenes each model wins."""
    out: dict[str, int] = {}
    for r in rows:
        m = (r.get("winner") or {}).get("model")
        if m:
            out[m] = out.get(m, 0) + 1
    return dict(sorted(out.items(), key=lambda kv: -kv[1]))
