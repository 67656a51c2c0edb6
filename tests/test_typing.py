"""pulsemap is a typed package (PEP 561 ``py.typed``): mypy checks the README's and the docs' Python
examples against an installed wheel, and sees pulsemap's own types there (a wrong argument type is
an error, a derivation is a Derivation)."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import installed_wheel

ROOT = Path(__file__).resolve().parents[1]
UNTYPED = ("sympy", "matplotlib", "pandas", "numba", "scipy", "mpmath")  # libraries without types of their own


def python_blocks(path: Path) -> list[str]:
    """The Python examples of a Markdown (```python fences) or reStructuredText (``.. code-block:: python``) file."""
    text = path.read_text(encoding="utf-8")
    if path.suffix == ".md":
        return re.findall(r"^```python\n(.*?)^```", text, flags=re.M | re.S)
    blocks = []
    for match in re.finditer(r"^\.\. code-block:: python\n((?:\n|   .*\n)+)", text, flags=re.M):
        blocks.append("\n".join(line[3:] for line in match.group(1).splitlines()).strip() + "\n")
    return blocks


def examples() -> dict[str, str]:
    """Every file's Python examples as one module (a later block may use an earlier one's names)."""
    out = {}
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.rst"))]:
        blocks = python_blocks(path)
        if blocks:
            out[path.stem] = "import pulsemap\n\n" + "\n".join(blocks)
    return out


def test_the_package_is_marked_typed_and_the_examples_are_found():
    assert (ROOT / "py.typed").is_file()
    assert '"pulsemap" = ["py.typed"]' in (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    found = examples()
    assert {"README", "quickstart", "api", "perturbation"} <= set(found)
    assert all(compile(code, name, "exec") for name, code in found.items())  # a broken extraction fails here


@pytest.mark.process
def test_mypy_passes_the_examples_against_an_installed_wheel(tmp_path):
    pytest.importorskip("mypy")
    venv, site = installed_wheel(tmp_path)
    python = venv / ("Scripts/python.exe" if os.name == "nt" else "bin/python")
    assert (site / "pulsemap" / "py.typed").is_file()

    files = []
    for name, code in examples().items():
        files.append(tmp_path / f"example_{name}.py")
        files[-1].write_text(code, encoding="utf-8")
    wrong = tmp_path / "wrong_types.py"  # the control: pulsemap's types are seen, not Any
    wrong.write_text('import pulsemap\n\nd = pulsemap.derive("-mu*v")\nreveal_type(d)\nreveal_type(d.symbols)\n'
                     'pulsemap.run("default", rank="yes")\n', encoding="utf-8")
    config = tmp_path / "mypy.ini"
    config.write_text("[mypy]\ncache_dir = " + str(tmp_path / "mypy_cache") + "\n"
                      + "".join(f"[mypy-{lib}.*]\nignore_missing_imports = True\n" for lib in UNTYPED),
                      encoding="utf-8")
    env = {k: v for k, v in os.environ.items() if not k.startswith(("MYPY", "PYTHON"))}

    def mypy(*paths: Path) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "mypy", "--config-file", str(config), "--python-executable",
                               str(python), "--no-error-summary", *map(str, paths)], capture_output=True, text=True,
                              timeout=600, env=env, cwd=tmp_path)

    ok = mypy(*files)
    assert ok.returncode == 0, ok.stdout + ok.stderr
    control = mypy(wrong)
    assert control.returncode == 1, control.stdout + control.stderr
    assert 'Revealed type is "pulsemap.solvers.api.derivation.Derivation"' in control.stdout, control.stdout
    assert 'Argument "rank" to "run" has incompatible type "str"; expected "bool"' in control.stdout, control.stdout
    assert "missing library stubs or py.typed marker" not in control.stdout
