"""Progress on stderr (solvers/studies/progress.py): k of N, ETA, plain lines, sweep points by parameters."""

from __future__ import annotations

import io

import pytest

from pulsemap.solvers.studies.progress import Progress, describe, duration


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def test_duration_reads_like_a_person_would_say_it():
    assert duration(8.25) == "8.2 s"
    assert duration(45.2) == "45 s"
    assert duration(125) == "2 min 05 s"
    assert duration(3720) == "1 h 02 min"


def test_k_of_n_and_eta_from_the_items_done():
    clock, lines = Clock(), []
    p = Progress("table", 5, clock=clock, sink=lines.append)
    p.start("fig6-eps0.1")
    clock.t += 4.0
    p.finish("fig6-eps0.1", "done", 4.0)
    clock.t += 6.0
    p.finish("fig6-eps0.3", "done", 6.0)
    assert lines[0] == "[table] 1/5 fig6-eps0.1 ..."
    assert lines[1] == "[table] 1/5 fig6-eps0.1: done in 4.0 s (elapsed 4.0 s, ETA 16 s)"
    assert lines[2] == "[table] 2/5 fig6-eps0.3: done in 6.0 s (elapsed 10 s, ETA 15 s)"  # 10 s / 2 x 3 left
    clock.t += 1.0
    for _ in range(3):
        p.finish("x")
    assert lines[-1].startswith("[table] 5/5 x: done (elapsed") and "ETA" not in lines[-1]
    assert all("\r" not in line and "\x1b" not in line for line in lines)  # readable in a log file


def test_disabled_prints_nothing(capsys):
    p = Progress("suite", 3, enabled=False)
    p.start("a")
    p.finish("a")
    assert capsys.readouterr().err == ""


def test_default_sink_is_stderr_not_stdout(capsys):
    Progress("bench", 1).finish("default")
    out = capsys.readouterr()
    assert out.out == "" and out.err.startswith("[bench] 1/1 default: done")


def test_sweep_points_are_named_by_what_varies():
    chain = {"R": "-mu*v", "eps": 0.1, "params": {"mu": 1.5}, "velocity": 0.3, "contacts": [16, 400]}
    points = [{**chain, "params": {"mu": mu}, "velocity": v0} for v0 in (0.3, 2.3) for mu in (1.5, 2.0)]
    labels = describe(points)
    assert labels == ["mu=1.5, velocity=0.3", "mu=2, velocity=0.3", "mu=1.5, velocity=2.3", "mu=2, velocity=2.3"]
    assert describe([chain]) == ["point 1"]


def test_run_sweep_progress_shows_parameters_not_hashes():
    from pulsemap.solvers.studies.sweep import point_key, run_sweep

    stream = io.StringIO()
    points = [{"a": 1.0, "b": "x"}, {"a": 2.0, "b": "x"}]
    run_sweep(_double, points, max_workers=1, progress=True, stream=stream, label="sweep")
    text = stream.getvalue()
    assert "[sweep] 1/2 a=1: ok" in text and "[sweep] 2/2 a=2: ok" in text and "ETA" in text
    assert point_key(points[0]) not in text


def _double(p: dict) -> dict:
    return {"y": 2 * p["a"]}


def test_suite_reports_each_case_before_and_after(monkeypatch):
    from pulsemap.solvers.studies import suite

    monkeypatch.setattr(suite, "run_case", lambda name, check, repeats: {"scene": name, "status": "ok",
                                                                          "wall_s": 0.5})
    lines: list[str] = []
    suite.run_suite(["damp-10", "eps1"], log=lines.append)
    assert lines[0] == "[suite] 1/2 damp-10 ..."
    assert lines[1].startswith("[suite] 1/2 damp-10: ok in 0.5 s (elapsed")
    assert lines[3].startswith("[suite] 2/2 eps1: ok in 0.5 s")


@pytest.mark.parametrize("quiet", [True, False])
def test_progress_log_is_plain_stderr_unless_quiet(capsys, quiet):
    from pulsemap.solvers.cli.common import progress_log

    progress_log(quiet)("[x] 1/2")
    assert capsys.readouterr().err == ("" if quiet else "[x] 1/2\n")


def test_on_a_terminal_a_sweep_is_one_updating_line_and_a_failed_point_keeps_its_line(monkeypatch):
    """run_sweep on a terminal: the points replace one another's line, a failed one stays on screen,
    and the last line says N/N with the time; in a log every point keeps its line."""
    from conftest import Terminal
    from pulsemap.solvers.chain.dns_progress import PROGRESS_ENV
    from pulsemap.solvers.studies.sweep import run_sweep

    monkeypatch.setenv(PROGRESS_ENV, "auto")
    points = [{"a": float(a)} for a in range(1, 6)]
    tty, log = Terminal(), io.StringIO()
    for stream in (tty, log):
        run_sweep(_fails_at_three, points, max_workers=1, progress=True, stream=stream, label="sweep")
    screen = tty.screen()
    assert screen[0].startswith("[sweep] 5 points") and len(screen) == 4, screen
    assert screen[1].startswith("[sweep] 3/5 a=3: FAILED") and screen[2].startswith("[sweep] 5/5 a=5: ok")
    assert screen[3].startswith("[sweep] done: 5 run")
    assert len(log.getvalue().splitlines()) == 7 and "\x1b" not in log.getvalue()


def _fails_at_three(p: dict) -> dict:
    if p["a"] == 3:
        raise ValueError("three")
    return {"y": p["a"]}
