"""solvers/data/plotting.py: figures without pyplot (the caller's backend untouched, PNG in Jupyter), one
clear error when matplotlib is missing."""

from __future__ import annotations

import sys

import pytest

from pulsemap.solvers.data.plotting import NEEDS_MATPLOTLIB, figures


class _Error(ValueError):
    pass


@pytest.mark.parametrize("module", ["matplotlib", "matplotlib.figure"])
def test_missing_matplotlib_is_a_one_line_user_error(monkeypatch, module):
    monkeypatch.setitem(sys.modules, module, None)  # import raises ImportError
    with pytest.raises(_Error) as info:
        figures(_Error)
    assert str(info.value) == NEEDS_MATPLOTLIB and 'pip install "pulsemap[plot]"' in str(info.value)
    assert info.value.__cause__ is None and info.value.__suppress_context__


def test_every_plot_names_its_own_error_when_matplotlib_is_missing(monkeypatch):
    from pulsemap.solvers.studies.bench import BenchError
    from pulsemap.solvers.studies.bench import plot as bench_plot
    from pulsemap.solvers.studies.bifurcation import BifurcationError
    from pulsemap.solvers.studies.bifurcation import plot as bifurcation_plot
    from pulsemap.solvers.studies.ensemble import EnsembleError
    from pulsemap.solvers.studies.ensemble import plot as ensemble_plot
    from pulsemap.solvers.studies.methods import RunError
    from pulsemap.solvers.studies.run.report import plot as run_plot

    monkeypatch.setitem(sys.modules, "matplotlib", None)
    for plot, error in ((run_plot, RunError), (bench_plot, BenchError), (bifurcation_plot, BifurcationError),
                        (ensemble_plot, EnsembleError)):
        with pytest.raises(error, match="needs matplotlib"):
            plot({}, "unused.png")


def test_figures_leave_the_backend_alone_and_render_as_png():
    matplotlib = pytest.importorskip("matplotlib")
    before = matplotlib.get_backend()
    fig, ax = figures().subplots(figsize=(2, 1.5))
    ax.plot([0, 1], [1, 0])
    assert matplotlib.get_backend() == before
    assert fig._repr_png_()[:8] == b"\x89PNG\r\n\x1a\n"  # what Jupyter shows without %matplotlib inline


@pytest.mark.parametrize("command", [["run", "default"], ["bench", "default", "--quick"],
                                     ["bifurcation", "vdp-mu3-v2.3", "--param", "mu", "--range", "1", "2"],
                                     ["ensemble", "fig13-seed1", "--realisations", "2"]])
def test_plot_without_matplotlib_fails_before_the_run(monkeypatch, tmp_path, capsys, command):
    """One hint everywhere, exit 2, and nothing computed (the studies would raise if called)."""
    from pulsemap.solvers.cli import main as cli
    from pulsemap.solvers.studies import bench, bifurcation, ensemble, run

    def never(*args, **kwargs):
        raise AssertionError("the run started before --plot was checked")

    for module, name in ((run, "run_scene"), (bench, "run_bench"), (bifurcation, "bifurcation"),
                         (ensemble, "ensemble")):
        monkeypatch.setattr(module, name, never)
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    assert cli.main(command + ["--plot", str(tmp_path / "f.png")]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"pulsemap: error: {NEEDS_MATPLOTLIB}"
    assert not (tmp_path / "f.png").exists()


def _run_result(alive: list[bool]) -> dict:
    contacts = list(range(16, 16 + len(alive)))
    dns = [0.7 * 0.8 ** k if a else None for k, a in enumerate(alive)]
    return {"scene": {"name": "t"}, "contacts": contacts, "choices": {"variant": "paper", "profile": "exact"},
            "peaks": {"dns": dns, "map": [0.7 * 0.85 ** k for k in range(len(alive))], "longwave": None,
                      "energy-law": [0.7 * 0.82 ** k for k in range(len(alive))]},
            "dns": {"alive": alive, "stop_reason": "pulse died at contact 21 (peak below 0.001 x peak)"}}


def test_run_figure_has_a_legend_entry_per_line_and_marks_the_stop():
    from pulsemap.solvers.data.plotting import peaks_figure

    plt = figures()
    fig = peaks_figure(_run_result([True] * 5 + [False] * 3), plt, log_y=True)
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert len(labels) == len(ax.lines) == 4  # dns, map, energy-law, stop marker (no longwave values)
    assert labels[0] == "DNS" and labels[1] == "map (paper, exact)" and labels[2] == "energy-law"
    assert labels[3].startswith("DNS pulse lost after contact 20: pulse died at contact 21")
    stop = ax.lines[3]
    assert list(stop.get_xdata()) == [20] and stop.get_ydata()[0] == pytest.approx(0.7 * 0.8 ** 4)
    assert ax.get_yscale() == "log"
    plt.close(fig)
    fig = peaks_figure(_run_result([True] * 8), plt)
    assert fig.axes[0].get_yscale() == "linear"
    assert all("lost" not in t.get_text() for t in fig.axes[0].get_legend().get_texts())  # no stop: no marker
    plt.close(fig)


def test_run_plot_writes_a_png(tmp_path):
    from pulsemap.solvers.studies.run.report import plot

    figures()
    path = tmp_path / "run.png"
    plot(_run_result([True] * 5 + [False] * 3), str(path), log_y=True)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_a_failed_figure_write_leaves_the_old_file_whole_and_no_temporary(tmp_path):
    pytest.importorskip("matplotlib")
    from pulsemap.solvers.data.plotting import figures, save

    fig, ax = figures().subplots()
    ax.plot([1, 2, 3])
    path = tmp_path / "peaks.png"
    save(fig, str(path))
    good = path.read_bytes()
    assert good.startswith(b"\x89PNG")

    def broken(*args, **kwargs):
        raise RuntimeError("renderer failed half-way")

    fig.savefig = broken
    with pytest.raises(RuntimeError):
        save(fig, str(path))
    assert path.read_bytes() == good and sorted(p.name for p in tmp_path.iterdir()) == ["peaks.png"]
