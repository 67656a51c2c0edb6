"""The first-use benchmarks (benchmarks/bench_first_run_default.py, bench_first_table.py) print the ratio they are
judged by, and their cold process starts as on a new machine: it builds the chain kernel even when the
environment names a kernel cache that has it (this session's NUMBA_CACHE_DIR, set by conftest)."""

from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.bench  # runs the benchmark scripts (CI: -m bench)
BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


@pytest.mark.parametrize("script, command", [("bench_first_run_default.py", "`pulsemap run default`"),
                                             ("bench_first_table.py", "`pulsemap table`")])
def test_a_first_use_benchmark_measures_a_new_machine_and_prints_its_ratio(script, command):
    env = {**os.environ}
    assert Path(env["NUMBA_CACHE_DIR"], "aot").is_dir()  # a kernel cache that holds the kernels already
    out = subprocess.run([sys.executable, str(BENCHMARKS / script), "--repeat", "1"], env=env, capture_output=True,
                         text=True, check=True).stdout
    built = re.search(r"^  cold \(every cache empty\) .* kernels built: (\[.*\])$", out, re.M)
    installed = re.search(r"^  kernels built at install, in the package: (\d+) ", out, re.M)
    assert installed, out
    want = [0] if int(installed.group(1)) else [1]  # an editable install's cold process builds the run's one kernel
    assert built and ast.literal_eval(built.group(1)) == want, out
    cpu = {m.group(1).strip(): float(m.group(2)) for m in re.finditer(r"^  (\w[\w ,()]*?) +CPU +([\d.]+) s", out, re.M)}
    assert set(cpu) == {"cold (every cache empty)", "warm", "kernels built ahead, rest cold"}, out
    ratio = re.search(rf"^ratio: first {re.escape(command)} CPU / ([\d.]+) s target = ([\d.]+) ", out, re.M)
    assert ratio and float(ratio.group(2)) == pytest.approx(cpu["cold (every cache empty)"] / float(ratio.group(1)),
                                                            abs=0.006), out
