"""Benchmark: the moving window behind a damped pulse against the full chain, as its target is judged (error <= the
accuracy asked for), at the exponents, strengths, speeds and accuracies the window's damped rule was fitted on.

Run: python benchmarks/bench_window_damped.py [--exponents 1.5,2,2.5,3] [--last 400]

Per case (Hertz exponent n, a contact-law term eps_c c d^a w from contact 16 on: a dashpot a = 0 or Kuwabara-Kono
a = 1/2, bead 1's velocity v0): the full chain's peaks (compiled DOP853, rtol 1e-13, up to contact LAST, while the
pulse keeps a tenth of its entry peak: StopRules.death_fraction), then the 'auto' window's at accuracies 1e-6, 1e-8
and 1e-10 (window.rule_for_accuracy: its beads behind, window.damped_behind). Printed per accuracy: the largest
relative peak difference over the contacts alive in the full chain, its ratio to the accuracy ("lost": the window's
pulse died elsewhere), and the beads behind. A ratio above 1 can be the run's own floor, not the window's: at 1e-10
with v0 = 0.01, and for Kuwabara-Kono at n = 3, v0 = 0.01, where a window wider than the chain is as far off the full
chain (docs/contact.rst, "The moving window and damped contacts").
"""

from __future__ import annotations

import argparse

import numpy as np

from pulsemap.solvers.chain.contact_force import ContactTable
from pulsemap.solvers.chain.dns import Chain, Integrator, simulate
from pulsemap.solvers.chain.peaks import StopRules, velocity_scale
from pulsemap.solvers.chain.window import WindowSpec

FIRST = 16  # the first damped contact
TERMS = ((0.0, 0.05), (0.0, 0.2), (0.0, 0.5), (0.0, 1.0), (0.5, 0.5), (0.5, 1.0))  # (a, eps_c c) of eps_c c d^a w
SPEEDS = (1.0, 0.01)
ACCURACIES = (1e-6, 1e-8, 1e-10)


def damped_chain(n: float, a: float, c: float, v0: float, beads: int) -> Chain:
    """A chain of ``beads`` beads whose contacts from FIRST on carry eps_c c d^a w."""
    coef = np.zeros((1, beads - 1))
    coef[0, FIRST - 1:] = c
    return Chain(beads, n, v0, contact=ContactTable(np.array([[a, 1.0]]), coef))


def worst(window, full) -> float:
    """The largest relative peak difference over the contacts alive in ``full`` (inf: the window lost the pulse)."""
    live = full.alive
    if not window.alive[live].all():
        return float("inf")
    return float(np.max(np.abs(window.peaks[live] / full.peaks[live] - 1.0)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--exponents", default="1.5,2,2.5,3", help="Hertz exponents n (default 1.5,2,2.5,3)")
    parser.add_argument("--last", type=int, default=400, help="the last contact (default 400)")
    args = parser.parse_args()
    integrator = Integrator(method="DOP853", rtol=1e-13, atol=1e-15)
    stop = StopRules(death_fraction=0.1)
    print("  n      v0   a  eps c   gamma  live  " + "  ".join(f"{acc:g}: error ratio behind" for acc in ACCURACIES))
    for n in (float(x) for x in args.exponents.split(",")):
        for v0 in SPEEDS:
            for a, c in TERMS:
                chain = damped_chain(n, a, c, v0, args.last + 15)
                full = simulate(chain, (FIRST, args.last), integrator=integrator, stop=stop)
                gamma = chain.contact.damping(n, velocity_scale(v0, n))
                line = f"{n:4.2f} {v0:6.2f} {a:3.1f} {c:5.2f} {gamma:7.3f} {int(full.alive.sum()):5d}  "
                if not full.alive.any():
                    print(line + "no live contact", flush=True)
                    continue
                cells = []
                for accuracy in ACCURACIES:
                    window = simulate(chain, (FIRST, args.last), integrator=integrator, stop=stop,
                                      window=WindowSpec(accuracy=accuracy))
                    error = worst(window, full)
                    ratio = "lost" if error == float("inf") else f"{error / accuracy:6.2f}"
                    cells.append(f"{error:8.1e} {ratio:>6} {window.window_rule.behind:4d}")
                print(line + "  ".join(cells), flush=True)


if __name__ == "__main__":
    main()
