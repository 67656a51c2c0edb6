"""Benchmark: the first ``pulsemap run default`` on a new machine, in CPU seconds, against its target (<= 6 s).

Run: python benchmarks/bench_first_run_default.py [--repeat N]

Every cold process starts with every cache a new machine lacks empty (first_use.new_machine_env: the pulsemap
cache with the ahead-of-time kernels, numba's cache, whatever PULSEMAP_CACHE_DIR or NUMBA_CACHE_DIR this
environment sets); its CPU time counts the kernel's build in a child process and the C compiler. Printed:
cold (best of N, with the kernels each cold process built), warm, with the kernels built ahead (at install) and
everything else cold, and the ratio it is judged by: cold CPU / 6 s.
"""

from __future__ import annotations

import first_use

TARGET_S = 6.0

if __name__ == "__main__":
    first_use.main(__doc__, lambda folder: [first_use.EXE, "run", "default", "--quiet"], TARGET_S,
                   "`pulsemap run default`")
