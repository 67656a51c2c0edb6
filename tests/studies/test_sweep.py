"""The sweep engine (solvers/sweep.py): keys, records, failures, resume after SIGKILL, Dask."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from pulsemap.solvers.data.records import encode_record

from pulsemap.solvers.studies.points import dns_task, plain_chain
from pulsemap.solvers.data.scene import load_scene, with_overrides
from pulsemap.solvers.studies.sweep import SweepError, load_generated, point_key, read_records, run_sweep

ROOT = Path(__file__).resolve().parents[2]
VDP = "vdp-mu3-v2.3"


def _vdp_points(values, last=30, v0=2.3):
    chain = plain_chain(with_overrides(load_scene(VDP), contacts=(16, last)))
    return [{**chain, "params": {"mu": float(mu)}, "velocity": v0} for mu in values]


def _square(p):  # a cheap task; module level so that process pools can pickle it
    if p["x"] < 0:
        raise ValueError(f"x = {p['x']} must be >= 0")
    return {"y": p["x"] ** 2}


def test_key_is_a_stable_hash_of_the_parameters():
    a = {"x": 1.5, "s": "ab", "l": [1, 2], "d": {"u": 1, "v": 2}}
    b = {"d": {"v": 2, "u": 1}, "l": [1, 2], "s": "ab", "x": 1.5}
    assert point_key(a) == point_key(b) and len(point_key(a)) == 16
    assert point_key(a) != point_key({**a, "x": 1.5000000001})
    assert point_key({"x": 2}) != point_key({"x": "2"})
    import numpy as np

    assert point_key({"x": np.float64(1.5), "l": np.array([1, 2])}) == point_key({"x": 1.5, "l": [1, 2]})
    with pytest.raises(SweepError, match="not finite"):
        point_key({"x": float("nan")})
    with pytest.raises(SweepError, match="only numbers, strings"):
        point_key({"x": object()})


def test_serial_sweep_records_each_point_and_a_rerun_skips_them(tmp_path):
    out = tmp_path / "s.jsonl"
    pts = [{"x": float(x)} for x in range(5)]
    res = run_sweep(_square, pts + [pts[0]], out, max_workers=1)  # duplicates run once
    assert [r["result"]["y"] for r in res.records] == [x * x for x in range(5)]
    assert (res.computed, res.skipped, res.failed) == (5, 0, 0)
    text = out.read_text()
    assert len(text.splitlines()) == 5
    again = run_sweep(_square, pts[::-1], out, max_workers=1)
    assert (again.computed, again.skipped) == (0, 5)
    assert out.read_text() == text  # nothing appended
    assert [r["result"]["y"] for r in again.records] == [x * x for x in range(4, -1, -1)]


def test_a_failed_point_is_recorded_and_the_sweep_goes_on(tmp_path):
    out = tmp_path / "f.jsonl"
    pts = [{"x": 1.0}, {"x": -2.0}, {"x": 3.0}]
    res = run_sweep(_square, pts, out, max_workers=2)
    assert res.failed == 1 and res.computed == 3
    bad = res.records[1]
    assert bad["status"] == "error" and bad["error"] == "ValueError: x = -2.0 must be >= 0"
    assert res.results() == [{"y": 1.0}, None, {"y": 9.0}]
    # a rerun skips it; --retry-failed runs it again (and it fails again, recorded again)
    assert run_sweep(_square, pts, out, max_workers=1).computed == 0
    retry = run_sweep(_square, pts, out, max_workers=1, retry_failed=True)
    assert retry.computed == 1 and retry.failed == 1


def test_a_real_dns_point_with_bad_input_fails_alone(tmp_path):
    pts = _vdp_points([3.0, 2.0])
    pts.insert(1, {**pts[0], "velocity": -1.0})
    res = run_sweep(dns_task, pts, tmp_path / "d.jsonl", max_workers=1)
    assert [r["status"] for r in res.records] == ["ok", "error", "ok"]
    assert "velocity must be > 0" in res.records[1]["error"]
    assert all(p is not None for p in res.records[0]["result"]["peaks"])


def test_a_line_cut_by_a_kill_is_ignored_and_repaired(tmp_path):
    out = tmp_path / "c.jsonl"
    pts = [{"x": float(x)} for x in range(3)]
    run_sweep(_square, pts[:2], out, max_workers=1)
    with out.open("a") as fh:
        fh.write('{"format": 1, "key": "')  # a record cut short
    assert len(read_records(out)) == 2
    res = run_sweep(_square, pts, out, max_workers=1)
    assert (res.computed, res.skipped) == (1, 2)
    lines = out.read_text().splitlines()
    assert len(lines) == 4 and json.loads(lines[-1])["params"] == {"x": 2.0}


def test_a_file_from_another_sweep_is_refused(tmp_path):
    out = tmp_path / "o.jsonl"
    run_sweep(_square, [{"x": 1.0}], out, max_workers=1)
    rec = json.loads(out.read_text())
    rec.pop("sha256")
    rec["params"] = {"x": 5.0}  # same key, other parameters (a record written so, with its digest)
    out.write_text(encode_record(rec) + "\n")
    with pytest.raises(SweepError, match="fresh output file"):
        run_sweep(_square, [{"x": 1.0}], out, max_workers=1)


def test_workers_load_generated_code_by_name_and_check_its_hash():
    chain = _vdp_points([3.0])[0]
    mod = load_generated(chain["force"])
    assert mod.PARAMS == ("mu",)
    with pytest.raises(SweepError, match="source hash"):
        load_generated({**chain["force"], "hash": "0" * 64})
    with pytest.raises(SweepError, match="not on this worker"):
        load_generated({"name": "force_0000000000000000", "hash": "0" * 64})
    # the point holds only plain data (no sympy objects)
    json.dumps(chain)


def test_process_pool_gives_the_serial_numbers(tmp_path):
    pts = _vdp_points([1.5, 2.0, 3.0])
    serial = run_sweep(dns_task, pts, None, max_workers=1)
    pool = run_sweep(dns_task, pts, None, max_workers=2)
    assert pool.executor.startswith("process pool")
    assert serial.results() == pool.results()


def test_dask_local_cluster_gives_the_serial_numbers(tmp_path):
    pytest.importorskip("dask")
    distributed = pytest.importorskip("distributed")
    pts = _vdp_points([1.5, 2.0, 3.0])
    serial = run_sweep(dns_task, pts, tmp_path / "serial.jsonl", max_workers=1)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        res = run_sweep(dns_task, pts, tmp_path / "dask.jsonl", executor=client.get_executor())
    assert res.executor == "ClientExecutor" and res.computed == 3
    assert res.results() == serial.results()
    assert [r["key"] for r in res.records] == [r["key"] for r in serial.records]


def _lines(path):
    return [line for line in path.read_text().splitlines() if line.strip()] if path.exists() else []


def _running(pid):
    """True while process ``pid`` exists and is not a zombie (Linux /proc)."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] != "Z"


@pytest.mark.process
def test_sweep_killed_and_restarted_does_not_recompute_finished_points(tmp_path):
    out = tmp_path / "kill.jsonl"
    args = [sys.executable, "-m", "pulsemap.solvers.cli.main", "bifurcation", VDP, "--param", "mu", "--range", "2", "3",
            "--points", "8", "--impulses", "2.3", "--contacts", "30", "--max-contacts", "30", "--refine", "0",
            "--workers", "2", "--predict-points", "5", "--profiles", "exact", "--set", "dns.engine=scipy",
            "--out", str(out)]  # no longer-chain reruns; scipy: slow enough that the kill lands mid-sweep
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.Popen(args, cwd=tmp_path, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while len(_lines(out)) < 2 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert proc.returncode == -signal.SIGKILL, proc.stderr.read().decode()[-2000:]
    first = _lines(out)
    assert 2 <= len(first) < 8, "the sweep finished before it could be killed"
    workers = {json.loads(line)["pid"] for line in first}
    assert proc.pid not in workers
    if Path("/proc").is_dir():  # the pool's workers exit with their killed parent
        deadline = time.monotonic() + 10
        while any(_running(p) for p in workers) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not any(_running(p) for p in workers)

    done = subprocess.run(args, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert f"{len(first)} already recorded" in done.stderr
    final = _lines(out)
    assert len(final) == 8  # one record per point: none computed twice
    assert final[: len(first)] == first  # the first run's records, untouched (same pid, same times)
    rerun = {json.loads(line)["pid"] for line in final[len(first):]}
    assert rerun and not rerun & workers  # the rest was computed by the rerun's workers

    # the same records as an uninterrupted run
    from pulsemap.solvers.cli.main import main

    ref = tmp_path / "ref.jsonl"
    assert main(args[3:-1] + [str(ref), "--quiet"]) == 0
    got = {r["key"]: (r["params"], r["result"]) for r in map(json.loads, final)}
    want = {r["key"]: (r["params"], r["result"]) for r in map(json.loads, _lines(ref))}
    assert got == want


@pytest.mark.process
def test_a_worker_runs_a_point_without_importing_sympy(tmp_path):
    point = tmp_path / "p.json"
    point.write_text(json.dumps(_vdp_points([3.0], last=20)[0]))
    code = ("import json, sys; from pulsemap.solvers.studies.points import dns_task; "
            f"r = dns_task(json.load(open({str(point)!r}))); "
            "print(len(r['peaks']), 'sympy' in sys.modules)")
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["6", "False"]


def test_workers_are_capped_at_the_cpu_count_with_a_note(tmp_path, monkeypatch, capsys):
    """--workers 1000000 forked a million processes; the pool gets os.cpu_count() (tested without forking)."""
    import concurrent.futures as cf

    from pulsemap.solvers.studies import sweep as sweep_mod

    made = []

    class FakePool(cf.ThreadPoolExecutor):
        def __init__(self, max_workers=None, initializer=None):
            made.append(max_workers)
            super().__init__(max_workers=1)

    monkeypatch.setattr(sweep_mod.os, "cpu_count", lambda: 3)
    monkeypatch.setattr(sweep_mod.cf, "ProcessPoolExecutor", FakePool)
    res = run_sweep(_square, [{"x": 1.0}, {"x": 2.0}], tmp_path / "w.jsonl", max_workers=1_000_000)
    assert made == [3] and res.results() == [{"y": 1.0}, {"y": 4.0}] and "3 workers" in res.executor
    assert capsys.readouterr().err == "pulsemap: note: 1000000 workers asked, this machine has 3 CPUs: running 3\n"
    assert sweep_mod.worker_count(2) == 2 and sweep_mod.worker_count(None) is None
