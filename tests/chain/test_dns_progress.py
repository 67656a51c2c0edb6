"""Progress of long DNS runs: k of N contacts, elapsed and ETA on stderr; silent when disabled."""

from __future__ import annotations

import io
import re

import pytest

from conftest import Terminal
from pulsemap.solvers.chain import dns_progress
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.chain.dns_progress import DNSProgress, duration


def test_lines_every_interval_with_an_eta_proportional_to_the_contacts_left():
    now = [0.0]
    lines: list[str] = []
    rep = DNSProgress("dns", 1000, every=5.0, clock=lambda: now[0], sink=lines.append)
    for t in range(1, 21):  # 1 s and 10 contacts per step
        now[0] = float(t)
        rep.update(0.5 * t, 10 * t, "DOP853")
    assert len(lines) == 4  # at 5, 10, 15, 20 s
    assert lines[-1] == "[dns] contact 200/1000, t = 10, elapsed 20 s, ETA 1 min 20 s (DOP853)"
    silent = DNSProgress("dns", 10, enabled=False, every=0.0, sink=lines.append)
    silent.update(1.0, 5)
    assert len(lines) == 4


@pytest.mark.parametrize("seconds, text", [(3.21, "3.2 s"), (45.4, "45 s"), (125, "2 min 05 s"), (3725, "1 h 02 min")])
def test_duration(seconds, text):
    assert duration(seconds) == text


@pytest.mark.parametrize("window", [None, "auto"])
def test_a_run_with_progress_reports_on_stderr_and_one_without_is_silent(window, capsys, monkeypatch):
    monkeypatch.setattr(dns_progress, "EVERY_S", 0.0)
    monkeypatch.setenv(dns_progress.PROGRESS_ENV, "auto")  # the tests switch the clock's lines off
    simulate(Chain(60, 1.5, 1.0), (10, 40),
             integrator=Integrator(engine="scipy"), progress=True, window=window)  # the compiled engine reports none
    err = capsys.readouterr().err.splitlines()
    assert err and all(re.match(r"^\[dns(-window)?\] contact \d+/40, t = ", line) for line in err)
    assert any("ETA" in line for line in err)
    simulate(Chain(60, 1.5, 1.0), (10, 40), integrator=Integrator(engine="scipy"), progress=False, window=window)
    assert capsys.readouterr().err == ""


def test_on_a_terminal_a_run_shows_one_updating_line_and_in_a_log_plain_lines(monkeypatch):
    """The same reporter: on a terminal each line replaces the last (the screen keeps one, the latest, with
    its ETA); in a file every line stays, without terminal codes; PULSEMAP_PROGRESS=lines keeps them too."""
    monkeypatch.setenv(dns_progress.PROGRESS_ENV, "auto")
    outputs = {}
    for name, stream in (("terminal", Terminal()), ("log", io.StringIO())):
        now = [0.0]
        rep = DNSProgress("dns", 100, every=1.0, clock=lambda: now[0], screen=dns_progress.StatusLine(stream))
        for k in range(1, 6):
            now[0] = float(k)
            rep.update(0.1 * k, 10 * k)
        outputs[name] = stream
    tty, log = outputs["terminal"], outputs["log"]
    assert tty.screen() == ["[dns] contact 50/100, t = 0.5, elapsed 5.0 s, ETA 5.0 s"]
    assert tty.getvalue().count("\n") == 5 and tty.getvalue().endswith("\n")  # a later print starts on its own line
    assert len(log.getvalue().splitlines()) == 5 and "\x1b" not in log.getvalue()
    monkeypatch.setenv(dns_progress.PROGRESS_ENV, "lines")
    plain = Terminal()
    screen = dns_progress.StatusLine(plain)
    for k in range(3):
        screen.show(f"line {k}")
    assert plain.screen() == ["line 0", "line 1", "line 2"] and "\x1b" not in plain.getvalue()


def test_progress_env_off_silences_the_clock_driven_lines_and_a_typo_is_refused(monkeypatch, capsys):
    monkeypatch.setenv(dns_progress.PROGRESS_ENV, "off")
    rep = DNSProgress("dns", 10, every=0.0)
    rep.update(1.0, 5)
    assert capsys.readouterr().err == "" and not rep.enabled
    lines: list[str] = []
    DNSProgress("dns", 10, every=0.0, sink=lines.append).update(1.0, 5)  # a caller's own sink still gets them
    assert len(lines) == 1
    monkeypatch.setenv(dns_progress.PROGRESS_ENV, "of")
    with pytest.raises(ValueError, match="PULSEMAP_PROGRESS='of': give auto, lines or off"):
        DNSProgress("dns", 10)
