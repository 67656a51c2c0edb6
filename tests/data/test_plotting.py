"""solvers/plotting.py: headless pyplot, one clear error when matplotlib is missing."""

from __future__ import annotations

import sys

import pytest

from pulsemap.solvers.data.plotting import NEEDS_MATPLOTLIB, pyplot


class _Error(ValueError):
    pass


@pytest.mark.parametrize("module", ["matplotlib", "matplotlib.pyplot"])
def test_missing_matplotlib_is_a_one_line_user_error(monkeypatch, module):
    monkeypatch.setitem(sys.modules, module, None)  # import raises ImportError
    with pytest.raises(_Error) as info:
        pyplot(_Error)
    assert str(info.value) == NEEDS_MATPLOTLIB and "pip install 'pulsemap[plot]'" in str(info.value)
    assert info.value.__cause__ is None and info.value.__suppress_context__


def test_every_plot_names_its_own_error_when_matplotlib_is_missing(monkeypatch):
    from pulsemap.solvers.studies.bench import BenchError
    from pulsemap.solvers.studies.bench import plot as bench_plot
    from pulsemap.solvers.studies.bifurcation import BifurcationError
    from pulsemap.solvers.studies.bifurcation import plot as bifurcation_plot
    from pulsemap.solvers.studies.ensemble import EnsembleError
    from pulsemap.solvers.studies.ensemble import plot as ensemble_plot
    from pulsemap.solvers.studies.run import RunError
    from pulsemap.solvers.studies.run import plot as run_plot

    monkeypatch.setitem(sys.modules, "matplotlib", None)
    for plot, error in ((run_plot, RunError), (bench_plot, BenchError), (bifurcation_plot, BifurcationError),
                        (ensemble_plot, EnsembleError)):
        with pytest.raises(error, match="needs matplotlib"):
            plot({}, "unused.png")


def test_pyplot_is_headless():
    pytest.importorskip("matplotlib")
    plt = pyplot()
    assert plt.get_backend().lower() == "agg"
