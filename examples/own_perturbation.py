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
# # Your own perturbation: a softening foundation with a velocity-squared term
#
# R(u, v) = alpha u + beta u^3 - c v^2 is not one of the paper's examples. It is a polynomial in
# u and v that vanishes at rest, so pulsemap derives its map and long-wave law (a quadrature here:
# three powers of B) and checks them against the DNS, with both solitary-wave profiles.

# %%
import pulsemap

R = "alpha*u + beta*u^3 - c*v^2"
d = pulsemap.derive(R, alpha=-1, beta=-0.5, c=0.2, eps=0.1)
print("0 =", d.map[0].rhs)  # d.map[0] is a sympy Eq(0, F1)
print(d.ode)
print("long-wave law:", d.law_kind, d.law or "(evaluated numerically)")

# %% [markdown]
# No scene file needed: start from a built-in scene and override the perturbation.

# %%
scene = pulsemap.scene(
    "default",
    R=R,
    **{"perturbation.eps": 0.1, "perturbation.params.alpha": -1, "perturbation.params.beta": -0.5,
       "perturbation.params.c": 0.2, "output.contacts": [16, 40]},
)
for profile in ("exact", "pade"):
    r = pulsemap.run(scene, methods=["dns", "map", "longwave"], profile=profile)
    print(profile, "RMS error % vs DNS:", {m: round(e["rms_pct"], 2) for m, e in r.errors.items()})

# %%
try:
    r.plot("own_perturbation.png")
    print("figure written to own_perturbation.png")
except ImportError as exc:
    print(exc)
