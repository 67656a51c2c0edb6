"""The dressed law's printed accuracy against the full-chain DNS: the numbers of docs/models.rst (its accuracy).

Run: python benchmarks/bench_dressed_accuracy.py [NAME ...]  (default: the scenes checked while building it; the
names of LATER were run once it was settled, those of LAST after the one fix LATER prompted)
Per scene (none of them sets anything in the estimate): the values the law gives on the DNS's live range, how
many lie within their printed estimate (all, and past the measured seed segment), the largest error and the
largest error/estimate past the seed segment; the contacts it withholds where the DNS has a pulse, and at how
many of those its value (the law without the cut) would have been within 5 %. Last, the totals.
"""

from __future__ import annotations

import sys
from dataclasses import replace

import pulsemap
from pulsemap.symbolic.profile import exact_profile
from pulsemap.solvers.models.dressed import ACCURACY, evaluate_dressed_law
from pulsemap.solvers.studies.dressed import coefficients, dressed_law, site_coefficient_functions
from pulsemap.solvers.studies.run.dressed import SEED_SPAN

SCENES = {
    "u2-eps0.05": ("fig6-eps0.1", {"perturbation.R": "-u^2", "perturbation.eps": 0.05}),
    "n3-found-damp-0.05": ("fig8-eps0.1", {"chain.exponent": 3.0, "perturbation.R": "-(u + v)",
                                           "perturbation.eps": 0.05}),
    "n3-found-damp-0.1": ("fig8-eps0.1", {"chain.exponent": 3.0, "perturbation.R": "-(u + v)",
                                          "perturbation.eps": 0.1}),
    "cubic-found-0.1": ("fig6-eps0.1", {"perturbation.R": "-u^3", "perturbation.eps": 0.1}),
    "fig8-eps0.1": ("fig8-eps0.1", {}),
    "fig8-eps0.3": ("fig8-eps0.3", {}),
    "fig8-v5": ("fig8-eps0.1", {"excitation.velocity": 5.0}),
    "fig6-eps0.1": ("fig6-eps0.1", {}),
    "vdp-mu3-v2.3": ("vdp-mu3-v2.3", {}),
    "vdp-mu1-v0.3": ("vdp-mu1-v0.3", {}),
    "vdp-mu3-eps0.025": ("vdp-mu3-v2.3", {"perturbation.eps": 0.025, "excitation.velocity": 0.9,
                                          "output.contacts": [16, 300]}),
    "vdp-mu5-eps0.025": ("vdp-mu3-v2.3", {"perturbation.params.mu": 5.0, "perturbation.eps": 0.025,
                                          "excitation.velocity": 0.9, "output.contacts": [16, 300]}),
    "mixed-0.2": ("fig8-eps0.1", {"perturbation.R": "-(u + u^3 + v)", "perturbation.eps": 0.2}),
    "n2-cubic-damp": ("fig8-eps0.1", {"chain.exponent": 2.0, "perturbation.R": "-(u^3 + v)",
                                      "perturbation.eps": 0.05}),
    "gain-loss": ("fig8-eps0.1", {"perturbation.R": "v - u^2*v", "perturbation.eps": 0.05}),
    "graded": ("fig6-eps0.1", {"perturbation.R": "-k*u", "perturbation.eps": 0.01,
                               "perturbation.params.k": "1 + (i - 16)/50"}),
}
# run only after the estimate was settled, to check it on scenes it had never met
LATER = {
    "u2-eps0.02": ("fig6-eps0.1", {"perturbation.R": "-u^2", "perturbation.eps": 0.02}),
    "u-u2-eps0.03": ("fig6-eps0.1", {"perturbation.R": "-(u + u^2)", "perturbation.eps": 0.03}),
    "cubic-found-0.05": ("fig6-eps0.1", {"perturbation.R": "-u^3", "perturbation.eps": 0.05}),
    "n2.5-found-damp": ("fig8-eps0.1", {"chain.exponent": 2.5, "perturbation.R": "-(u + v)", "perturbation.eps": 0.03}),
    "damp-eps0.05-v2": ("fig8-eps0.1", {"perturbation.eps": 0.05, "excitation.velocity": 2.0}),
    "vdp-mu2-eps0.05": ("vdp-mu3-v2.3", {"perturbation.params.mu": 2.0, "perturbation.eps": 0.05,
                                         "excitation.velocity": 1.5, "output.contacts": [16, 200]}),
    "n3-cubic-damp": ("fig8-eps0.1", {"chain.exponent": 3.0, "perturbation.R": "-(u^3 + v)", "perturbation.eps": 0.03}),
    "graded-damp": ("fig8-eps0.1", {"perturbation.R": "-k*v", "perturbation.eps": 0.1,
                                    "perturbation.params.k": "1 + (i - 16)/100"}),
}
# run once more after a fix the LATER ones prompted (the rate residual's quadrature), on scenes new again
LAST = {
    "u2-damp-n1.5": ("fig8-eps0.1", {"perturbation.R": "-(0.5*u^2 + v)", "perturbation.eps": 0.04}),
    "damp-n1.8": ("fig8-eps0.1", {"chain.exponent": 1.8, "perturbation.eps": 0.05}),
    "vdp-mu4-eps0.03": ("vdp-mu3-v2.3", {"perturbation.params.mu": 4.0, "perturbation.eps": 0.03,
                                         "excitation.velocity": 1.2, "output.contacts": [16, 250]}),
    "gain-cubic-loss": ("fig8-eps0.1", {"perturbation.R": "(1 - u^2)*v", "perturbation.eps": 0.05}),
    "graded-cubic": ("fig6-eps0.1", {"perturbation.R": "-k*u^3", "perturbation.eps": 0.05,
                                     "perturbation.params.k": "1 + (i - 16)/80"}),
    "n2-found-0.02": ("fig6-eps0.1", {"chain.exponent": 2.0, "perturbation.eps": 0.02}),
}
SCENES.update(LATER)
SCENES.update(LAST)


def uncut(scene, res: dict) -> dict:
    """The law's values without its cut (no estimate), from the run's seed: contact -> A (None: no value)."""
    law = dressed_law(scene.perturbation, scene.exponent, at_bead=float(scene.first_perturbed) - 0.5)
    coef = coefficients(law)
    i0 = float(scene.first_perturbed - 1)
    if not scene.perturbation.is_uniform:
        ends = float(scene.contacts[1])
        coef = replace(coef, c_of_i=site_coefficient_functions(scene.perturbation, law, i0, ends))
    S0 = exact_profile(scene.exponent).S0
    ev = evaluate_dressed_law(coef, S0, res["seed"]["A"], i0, res["contacts"])
    return dict(zip(res["contacts"], ev.run.A))


def main(names) -> None:
    totals = [0] * 6
    print(f"{'scene':<20} given within  past within  max err  max err/est past  withheld  good")
    for name in names:
        base, overrides = SCENES[name]
        scene = pulsemap.scene(base, **overrides)
        res = pulsemap.run(scene, methods=["dns", "dressed-law"]).to_dict()
        info = res["dressed-law"]
        law = res["peaks"]["dressed-law"] or [None] * len(res["contacts"])
        acc = info.get("accuracy") or [None] * len(res["contacts"])
        rows = [(c, d, q, a) for c, d, q, a in zip(res["contacts"], res["peaks"]["dns"], law, acc) if d is not None]
        given = [(c, abs(q / d - 1), a) for c, d, q, a in rows if q is not None]
        past = [g for g in given if g[0] > scene.first_perturbed - 1 + SEED_SPAN]
        held = [(c, d) for c, d, q, _ in rows if q is None]
        ran = held and "seed" in res and "failed" not in info and "refused" not in info
        A = uncut(scene, res) if ran else {}
        S0 = exact_profile(scene.exponent).S0
        good = sum(1 for c, d in held if A.get(c) is not None and abs(A[c] * S0 / d - 1) <= ACCURACY)
        counts = (len(given), sum(e <= a for _, e, a in given), len(past), sum(e <= a for _, e, a in past),
                  len(held), good)
        totals = [t + c for t, c in zip(totals, counts)]
        worst = max((e for _, e, _ in given), default=0.0)
        ratio = max((e / a for _, e, a in past), default=0.0)
        print(f"{name:<20} {counts[0]:5d} {counts[1]:6d} {counts[2]:5d} {counts[3]:6d}  {100 * worst:6.2f} %"
              f"  {ratio:16.3f}  {counts[4]:8d}  {counts[5]:4d}")
    print(f"{'total':<20} {totals[0]:5d} {totals[1]:6d} {totals[2]:5d} {totals[3]:6d}  {'':8}  {'':16}  "
          f"{totals[4]:8d}  {totals[5]:4d}")


if __name__ == "__main__":
    main(sys.argv[1:] or [name for name in SCENES if name not in LATER and name not in LAST])
