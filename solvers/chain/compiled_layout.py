"""The compiled DNS kernels' array layouts and return codes (no numba: the engine's Python side and the
ahead-of-time kernels read them without importing it).

fs, st: the kernels' resumable float and int state; cf, ci: their float and int configuration
(solvers/chain/compiled.prepare fills them; compiled_track.py and the kernels read them).
"""

# numba cache stamp: b6266238713c7034
from __future__ import annotations

# --- return codes of a kernel's run (solvers/chain/compiled.py turns them into PeakTracker's messages)
LAST_PEAKED, DIED, STALLED, T_MAX, BUDGET, BLOWUP, FAILED, NEED_ROOM, PAUSED, NONFINITE = 1, 2, 3, 4, 5, 6, 7, 8, 9, 10

# --- float state fs[...] (resumable between calls)
T, H, FACOLD, LEFT_X, LEFT_V, LEFT_T, E0, E_GONE, DRIFT, THRESH, LAST_PEAK_T, STALL, E_LAST = range(13)
N_FS = 13
# --- int state st[...]
LO, HI, NEXT, STEPS, NFEV, HAS_LEFT, REJECTED, DIED_AT, WIDEST, SHIFTS, STARTED, LOST, NJEV, VBEAD = range(14)
N_ST = 14  # NJEV: Jacobians (the stiff kernel's); VBEAD: the next bead whose velocity peak is tracked (1-based)
# --- float config cf[...]
EXP, RTOL, ATOL, T_MAXC, SCALE_X, SCALE_V, AHEAD_THR, PEAK_FRAC, DEATH_FRAC, OVERTAKE, STALL_FAC, E_LIMIT, \
    DELAY_FAC = range(13)
N_CF = 13
# --- int config ci[...]
BEADS, FIRST, LASTC, BEHIND, MAX_STEPS, COAST, CAPACITY, ENERGY_EVERY, PAUSE_EVERY = range(9)
N_CI = 9  # PAUSE_EVERY: return PAUSED after every this many accepted steps (0: never), for progress lines
