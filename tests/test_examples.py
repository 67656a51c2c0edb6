"""The examples/ scripts (jupytext percent format) run as written and produce what they announce."""

from __future__ import annotations

import runpy
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
SCRIPTS = sorted(EXAMPLES.glob("*.py"))


def test_examples_are_jupytext_percent_scripts():
    assert len(SCRIPTS) >= 2
    for script in SCRIPTS:
        text = script.read_text(encoding="utf-8")
        assert "format_name: percent" in text and "# %% [markdown]" in text and "\n# %%\n" in text, script.name


_RUNS: dict[str, tuple[dict, str, Path]] = {}


def _run(script: Path, tmp_path_factory, monkeypatch) -> tuple[dict, str, Path]:
    """Run ``script`` once per session in a fresh folder: (its namespace, its stdout, the folder)."""
    if script.stem not in _RUNS:
        folder = tmp_path_factory.mktemp(script.stem)
        monkeypatch.chdir(folder)
        monkeypatch.setattr(sys, "argv", [str(script)])
        from io import StringIO
        from contextlib import redirect_stdout

        buffer = StringIO()
        with redirect_stdout(buffer):
            namespace = runpy.run_path(str(script), run_name="__main__")
        _RUNS[script.stem] = (namespace, buffer.getvalue(), folder)
    return _RUNS[script.stem]


@pytest.mark.parametrize("script", SCRIPTS, ids=[s.stem for s in SCRIPTS])
def test_example_runs(script, tmp_path_factory, monkeypatch):
    namespace, out, folder = _run(script, tmp_path_factory, monkeypatch)
    result = namespace["result"] if "result" in namespace else namespace["r"]
    assert "dns" in result.peaks and result.errors  # ran against the DNS
    figure = folder / f"{script.stem}.png"
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        assert 'pip install "pulsemap[notebook]"' in out
    else:
        assert figure.read_bytes()[:4] == b"\x89PNG" and f"figure written to {figure.name}" in out
    assert r"\tag{23.1}" in out or "0 = " in out  # the map or the law printed


def test_van_der_pol_example_reaches_the_stable_shock(tmp_path_factory, monkeypatch):
    """The DNS peak of the example approaches the stable root of Eq. 41 it prints (within 1 %)."""
    ns, _, _ = _run(EXAMPLES / "van_der_pol.py", tmp_path_factory, monkeypatch)
    stable = max(ns["d"].stationary_peaks)
    assert ns["result"].peaks["dns"][-1] == pytest.approx(stable, rel=0.01)
