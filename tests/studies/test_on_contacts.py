"""Values at contacts (studies/points.py: ``on_contacts``, ``contact_slots``), against a plain dict lookup."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pulsemap.solvers.studies.extent import contact_slots, on_contacts


def by_dict(contacts, at, values, alive=None):
    """The definition, written out: the last finite, live value given for each contact."""
    flags = [True] * len(at) if alive is None else alive
    got = {int(c): float(v) for c, v, a in zip(at, values, flags) if a and v is not None and math.isfinite(v)}
    return [got.get(int(c)) for c in contacts]


@pytest.mark.parametrize("seed", range(20))
def test_on_contacts_is_the_dict_lookup(seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(0, 40))
    at = rng.integers(1, 30, size=n)  # repeats and gaps
    values = [None if r < 0.1 else (math.nan if r < 0.2 else (math.inf if r < 0.25 else float(x)))
              for r, x in zip(rng.random(n), rng.normal(size=n))]
    alive = (rng.random(n + int(rng.integers(-3, 3))) > 0.2).tolist()  # a list longer or shorter than at
    contacts = list(range(int(rng.integers(0, 10)), int(rng.integers(10, 35))))
    assert on_contacts(contacts, at, values) == by_dict(contacts, at, values)
    assert on_contacts(contacts, at, values, alive) == by_dict(contacts, at, values, alive)
    assert on_contacts(contacts, at.astype(float), np.array(values, dtype=float)) == by_dict(contacts, at, values)


def test_contact_slots_finds_the_last_occurrence():
    found, index = contact_slots([3, 4, 5, 9], [5, 3, 5, 4])
    assert found.tolist() == [True, True, True, False]
    assert index[:3].tolist() == [1, 3, 2]


def test_nothing_given_is_none_everywhere():
    assert on_contacts([1, 2], [], []) == [None, None]
    assert on_contacts([], [1], [0.5]) == []
