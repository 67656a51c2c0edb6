"""A warm run does only its work: with every derivation cached, the default run of a scene (every
method) and an overridden scene (--set) load neither sympy nor scipy, and give the numbers of the
run that derived them."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

RUN = ("import json, sys\nsys.argv = ['pulsemap'] + sys.argv[1:]\n"
       "from pulsemap.solvers.cli.main import main\ntry:\n    main()\nexcept SystemExit:\n    pass\n"
       "print(json.dumps(sorted(m for m in ('sympy', 'scipy') if m in sys.modules)), file=sys.stderr)")


def run(tmp_path, *args: str) -> tuple[dict, list[str]]:
    """The --json result of ``pulsemap run ARGS`` in a fresh interpreter, and which of sympy, scipy it loaded."""
    out = tmp_path / "out.json"
    proc = subprocess.run([sys.executable, "-c", RUN, "run", *args, "--quiet", "--json", str(out)],
                          capture_output=True, text=True, check=True)
    return json.loads(out.read_text()), json.loads(proc.stderr.strip().splitlines()[-1])


@pytest.mark.process
@pytest.mark.parametrize("extra", [(), ("--set", "dns.rtol=1e-9")])
def test_a_warm_default_run_loads_neither_sympy_nor_scipy(tmp_path, extra):
    first, _ = run(tmp_path, "vdp-mu3-v2.3", *extra)
    second, loaded = run(tmp_path, "vdp-mu3-v2.3", *extra)
    assert loaded == []
    assert set(second["choices"]["methods"]) >= {"dns", "map", "longwave"}
    assert second["longwave"]["kind"] == "quadrature"  # several powers of B: the marched law (longwave_eval.py)
    assert second["peaks"] == first["peaks"] and second["dns"]["alive"] == first["dns"]["alive"]
    assert second["scene"] == first["scene"]
