# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # A viscoelastic contact law with on-site damping: energy law and DNS
#
# The contact law F(d, w) = H(d) (d^n + eps_c P(d, w)) with the Kuwabara-Kono term P = gamma d^(1/2) w
# (w = d', the overlap's rate) from contact 16, and an on-site damping eps R = -0.01 v from bead 16. We derive
# the first-order energy law of P (docs/contact.rst) and the on-site map, then run the DNS of the chain
# (every engine takes the contact term) and compare.

# %%
import sympy

import pulsemap
from pulsemap.symbolic.contact import contact_monomials, contact_to_text, derive_contact

d_, w_, gamma = sympy.symbols("d w gamma", positive=True)
contact = derive_contact(contact_monomials(gamma * sympy.sqrt(d_) * w_), n=1.5, eps=0.03, params={"gamma": 1})
print(contact_to_text(contact))
print(contact.law.law)  # A(k) in closed form: one term, a power law

onsite = pulsemap.derive("-mu*v", mu=1, eps=0.01)
print(onsite.latex)  # the on-site part's amplitude map (Eq. 23) and long-wave law

# %% [markdown]
# A scene holds both: `[perturbation]` for R, `[contact]` for P (same shape, parameters per contact),
# and could hold `[masses]` too.

# %%
scene = pulsemap.scene({
    "name": "kuwabara-kono-and-damping",
    "excitation": {"velocity": 1.0},
    "perturbation": {"R": "-mu*v", "eps": 0.01, "params": {"mu": 1.0}},
    "contact": {"P": "gamma*d^(1/2)*w", "eps": 0.03, "params": {"gamma": 1.0}},
    "output": {"contacts": [16, 80], "methods": ["dns", "energy-law", "energy-map"]},
})
result = pulsemap.run(scene)
print(result)
for model in ("energy-law", "energy-map"):
    e = result.errors[model]
    print(f"{model}: RMS error against the DNS {e['rms_pct']:.3g} % (max {e['max_pct']:.3g} %) over the live range")

# %% [markdown]
# The figure needs matplotlib (`pip install "pulsemap[notebook]"`).

# %%
try:
    result.plot("contact_damping.png")
    print("figure written to contact_damping.png")
except ImportError as exc:
    print(exc)
