"""examples/quickstart.ipynb runs in a real Jupyter kernel (this interpreter) and shows what a notebook
user needs without any magic: the derivation in LaTeX, the result as an HTML table, the figure as PNG."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

NOTEBOOK = Path(__file__).resolve().parent.parent / "examples" / "quickstart.ipynb"


def test_the_notebook_is_stored_without_outputs():
    nb = json.loads(NOTEBOOK.read_text(encoding="utf-8"))
    code = [c for c in nb["cells"] if c["cell_type"] == "code"]
    assert code and all(c["outputs"] == [] and c["execution_count"] is None for c in code)
    assert not any("%matplotlib" in "".join(c["source"]) for c in code)


@pytest.mark.process
def test_the_notebook_shows_latex_html_and_a_figure(tmp_path, monkeypatch):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    pytest.importorskip("matplotlib")
    # a kernel spec for this interpreter, found through JUPYTER_PATH (a fresh CI venv has none registered)
    spec = tmp_path / "kernels" / "pulsemap-test"
    spec.mkdir(parents=True)
    (spec / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "pulsemap test", "language": "python"}))
    monkeypatch.setenv("JUPYTER_PATH", str(tmp_path))
    monkeypatch.setenv("MPLBACKEND", "agg")  # no inline backend either: the figure must show itself
    nb = nbformat.read(str(NOTEBOOK), as_version=4)
    nbclient.NotebookClient(nb, kernel_name="pulsemap-test", timeout=600,
                            resources={"metadata": {"path": str(tmp_path)}}).execute()
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs]
    assert not [o for o in outputs if o.output_type == "error"]
    data = [o.get("data", {}) for o in outputs]
    latex = next(d["text/latex"] for d in data if "text/latex" in d)
    assert "\\begin{align}" in latex and "mu" in latex
    html = next(d["text/html"] for d in data if "text/html" in d)
    assert "fig8-eps0.3" in html and "<td>map</td>" in html and "RMS error %" in html
    png = next(d["image/png"] for d in data if "image/png" in d)  # base64 text
    import base64

    assert base64.b64decode(png)[:8] == b"\x89PNG\r\n\x1a\n"
    rms = next(float(d["text/plain"]) for d in data if set(d) == {"text/plain"} and d["text/plain"][:1].isdigit())
    assert f"<td>{rms:.3g}</td>" in html  # the number the table shows is the Result's
    # the free-parameter cells: lambdify in the notebook's own symbols gives what subs by name gives, and
    # that is the law of derive(mu=1) at contact 20 (a decaying amplitude, 0 < A < A_0)
    import ast

    import pulsemap

    pair = next(ast.literal_eval(d["text/plain"]) for d in data if d.get("text/plain", "").startswith("("))
    fixed = pulsemap.derive("-mu*v", mu=1, eps=0.3)
    expected = float(fixed.law.rhs.subs(fixed.values).subs({"A_0": 1, "i_0": 0, "i": 20}))
    assert pair[0] == pytest.approx(pair[1], rel=1e-12) and pair[0] == pytest.approx(expected, rel=1e-12)
    assert 0 < pair[0] < 1
