"""Progress of long DNS runs: k of N contacts, elapsed and ETA on stderr; silent when disabled."""

from __future__ import annotations

import re

import pytest

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
    simulate(Chain(60, 1.5, 1.0), (10, 40),
             integrator=Integrator(engine="scipy"), progress=True, window=window)  # the compiled engine reports none
    err = capsys.readouterr().err.splitlines()
    assert err and all(re.match(r"^\[dns(-window)?\] contact \d+/40, t = ", line) for line in err)
    assert any("ETA" in line for line in err)
    simulate(Chain(60, 1.5, 1.0), (10, 40), integrator=Integrator(engine="scipy"), progress=False, window=window)
    assert capsys.readouterr().err == ""
