"""The contact-law conformance suite on laws with per-contact history
(``contact_history_names``: the collision evaluator takes the contact's row, ``(g, pars, hist,
out)``), its restart check on every shipped law, and the named geometry builders.

A law that counts, in its contact's row, the steps its pair has been in contact and softens
with the count passes every check; the same law with
a planted fault fails the check that concerns it: a write past its declared column, a compiled
evaluator that differs from its Python form only on a history row it has seen, and a count kept
outside the history (which a restart loses).
"""
from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from siku_core.contact_law import G_AREA, G_K, G_MEFF, G_NX, G_WIDTH, J_DT, J_S1X, J_W
from siku_core.plugins import get_registry
from siku_core.testing import contact_conformance as cc
from siku_plugins.contact_laws import Collision, DistributedSpring, collision_evaluator, \
    spring_evaluator


@njit(cache=True)
def aging_evaluator(g, pars, hist, out):
    """The collision law softened by ``1 / (1 + steps / 100)`` (a contact that wears: passive,
    less comes back than went in); counts its steps in ``hist[0]``."""
    collision_evaluator(g, pars, out)
    f = 1.0 / (1.0 + hist[0] / 100.0)
    out[0] *= f
    out[1] *= f
    out[2] *= f
    hist[0] += 1.0


class Aging(Collision):
    name = "contact_age_conformance_test"
    contact_history_names = ("steps",)
    collision_evaluator = aging_evaluator


@njit(cache=True)
def spilling_evaluator(g, pars, hist, out):
    aging_evaluator(g, pars, hist, out)
    hist[1] = 1.0  # a column the law does not declare


class Spilling(Aging):
    name = "contact_spill_test"
    collision_evaluator = spilling_evaluator


def _drift_python(g, pars, hist, out):
    """As the compiled form below, except that the count enters the force: the two differ only
    once the row is not zero (the second evaluation), which a check without the row misses."""
    collision_evaluator(g, pars, out)
    out[0] *= 1.0 / (1.0 + hist[0])
    hist[0] += 1.0


@njit(cache=True)
def drifting_evaluator(g, pars, hist, out):
    collision_evaluator(g, pars, out)
    hist[0] += 1.0


class Drifting(Aging):
    name = "contact_drift_test"
    collision_evaluator = drifting_evaluator


@njit(cache=True)
def forgetful_evaluator(g, pars, out):
    """Counts its steps in contact in a slot of its parameter vector instead of a history row
    (the engine packs the vector once per run): a restart starts the count again."""
    collision_evaluator(g, pars, out)
    f = 1.0 / (1.0 + pars[-1] / 10.0)
    out[0] *= f
    out[1] *= f
    out[2] *= f
    if g[G_AREA] > 0.0:
        pars[-1] += 1.0


class Forgetful(Collision):
    name = "contact_forgetful_test"
    collision_evaluator = forgetful_evaluator

    def collision_parameters(self):
        return np.append(super().collision_parameters(), 0.0)


@njit(cache=True)
def forgetful_joint_evaluator(g, pars, hist, out):
    """The same fault in a joint: the distributed spring, softened by its evaluations counted
    in a slot of its parameter vector instead of its history (compiles the joint loop only, a
    few seconds, where the collision fault compiles the collision loop, a minute or more)."""
    spring_evaluator(g, pars, hist, out)
    f = 1.0 / (1.0 + pars[-1] / 10.0)
    out[0] *= f
    out[1] *= f
    out[2] *= f
    pars[-1] += 1.0


class ForgetfulJoint(DistributedSpring):
    name = "forgetful_joint_test"
    joint_evaluator = forgetful_joint_evaluator

    def joint_parameters(self):
        return np.append(super().joint_parameters(), 0.0)


@pytest.fixture
def drifting():
    """Drifting with its pure-Python form swapped for ``_drift_python`` once compiled."""
    g = cc.collision_geometry(area=1e4, nx=1.0, width=100.0, k=5e8, meff=1e6)
    drifting_evaluator(g, Collision({}).collision_parameters(), np.zeros(1), np.zeros(4))
    keep = drifting_evaluator.py_func
    drifting_evaluator.py_func = _drift_python
    yield Drifting
    drifting_evaluator.py_func = keep


def test_a_law_with_per_contact_history_passes_every_check():
    cc.check_contact_law(Aging, {"damping_ratio": 0.0})


def test_the_row_is_passed_to_every_evaluation_compiled_and_python():
    """Control of the check's reach: the law raises a TypeError called with 3 arguments."""
    g = cc.collision_geometry(area=1e4, nx=1.0, width=100.0, k=5e8, meff=1e6)
    pars = Collision({}).collision_parameters()
    with pytest.raises(TypeError):
        Aging.collision_evaluator.py_func(g, pars, np.zeros(4))
    (hist,) = cc.contact_history_row(Aging)
    out = np.zeros(4)
    Aging.collision_evaluator(g, pars, hist, out)
    assert hist.tolist() == [1.0] and out[0] > 0
    assert cc.contact_history_row(Collision) == ()


@pytest.mark.parametrize("law, check, expected", [
    ("spilling", cc.check_history,
     "contact_spill_test: history: the collision evaluator wrote"),
    ("drifting", cc.check_compiled_matches_python,
     "contact_drift_test: compiled == python: compiled collision evaluator"),
    pytest.param("forgetful", cc.check_restart,
                 "contact_forgetful_test: restart: overlapping pair: ", marks=pytest.mark.slow),
    ("forgetful_joint", cc.check_restart, "forgetful_joint_test: restart: jointed pair: "),
])
def test_the_suite_fails_a_history_law_with_a_planted_fault(law, check, expected, request):
    law_cls = {"spilling": Spilling, "forgetful": Forgetful,
               "forgetful_joint": ForgetfulJoint}.get(law) or request.getfixturevalue(law)
    with pytest.raises(AssertionError) as ei:
        check(law_cls, {"damping_ratio": 0.0})
    assert str(ei.value).startswith(expected), str(ei.value)


@pytest.mark.parametrize("name", get_registry().names("contact_law"))
def test_every_shipped_law_restarts_bit_for_bit(name):
    cc.check_restart(get_registry().get("contact_law", name))


def test_named_geometry_builders_follow_the_layouts():
    g = cc.collision_geometry(area=1e4, nx=1.0, width=100.0, k=5e8, meff=1e6)
    assert g.shape == (len(cc.collision_geometry()),)
    assert (g[G_AREA], g[G_NX], g[G_WIDTH], g[G_K], g[G_MEFF]) == (1e4, 1.0, 100.0, 5e8, 1e6)
    assert np.count_nonzero(g) == 5
    j = cc.joint_geometry(s1x=0.1, w=2000.0, dt=0.5)
    assert (j[J_S1X], j[J_W], j[J_DT]) == (0.1, 2000.0, 0.5) and np.count_nonzero(j) == 3
    with pytest.raises(TypeError, match="unknown entry normal; the entries are area, cx"):
        cc.collision_geometry(normal=1.0)
