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
# # A damped granular chain: law, map and DNS
#
# Linear damping, R(u, v) = -mu v (paper Eqs. 34-36). We derive the amplitude map and the
# long-wave law, then run both against a direct numerical simulation of the chain.
# (Open with jupytext as a notebook, or run it as a script.)

# %%
import pulsemap

d = pulsemap.derive("-mu*v", mu=1, eps=0.3)
print(d.law_kind, "with lambda_L =", d.rate)
print(d.law)
print(d.latex)  # in a notebook, `d` alone renders the equations

# %% [markdown]
# The built-in scene `fig8-eps0.3` is this chain (paper Fig. 8); a short stretch of contacts
# keeps the example quick.

# %%
scene = pulsemap.scene("fig8-eps0.3", **{"output.contacts": [16, 40]})
result = pulsemap.run(scene, methods=["dns", "map", "longwave"])
print(result)
for model in ("map", "longwave"):
    e = result.errors[model]
    print(f"{model}: RMS error against the DNS {e['rms_pct']:.3g} % (max {e['max_pct']:.3g} %) over the live range")

# %% [markdown]
# Peaks per contact are numpy arrays; the figure needs matplotlib (`pip install "pulsemap[notebook]"`).

# %%
print(result.contacts[:5], result.peaks["dns"][:5])
try:
    result.plot("damping.png")
    print("figure written to damping.png")
except ImportError as exc:
    print(exc)
