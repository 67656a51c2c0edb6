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
# # Stationary shocks of the Van der Pol chain
#
# R = -(u - mu (1 - u^2) v): a stiffness, a negative damping and a nonlinear damping (the reading
# of paper Eq. 37 the paper simulated, erratum 6 in the docs). Eq. 41 has two positive roots for
# mu = 3: a stable and an unstable stationary shock.

# %%
import pulsemap

d = pulsemap.derive("-(u - mu*(1 - u^2)*v)", mu=3, eps=0.1)
print(d.stationary)
for A, peak in zip(d.roots, d.stationary_peaks):
    print(f"stationary shock: A = {A:.6f}, peak = {peak:.6f}")
print("long-wave law:", d.law_kind)

# %% [markdown]
# A pulse entering above the unstable shock grows towards the stable one. The DNS and the map
# over the first contacts of the built-in scene (impulse v0 = 2.3):

# %%
result = pulsemap.run(pulsemap.scene("vdp-mu3-v2.3", contacts=(16, 45)), methods=["dns", "map"])
print(result)
print("last DNS peak", result.peaks["dns"][-1], "stable shock", max(d.stationary_peaks))

# %%
try:
    result.plot("van_der_pol.png")
    print("figure written to van_der_pol.png")
except ImportError as exc:
    print(exc)
