"""Instances of the contact loops' template (``siku_core.contact.kernel_cache``).

* A law's evaluator is recompiled without numba's reference counting for its instance of the
  loops, and that copy computes exactly what the evaluator computes (same code object, same
  arithmetic: bit for bit on random contacts).
* An evaluator that allocates cannot be compiled so; the loop then uses it as it is.
* The generated file is the rendered header and the template's source, unchanged; an
  evaluator that cannot be imported by name gets the generic instance, with the same results.
* Nothing in ``kernel_cache`` reads a function's source with regular expressions.
"""
from __future__ import annotations

import numpy as np
import pytest

from siku_core.contact import contact_loops, kernel_cache
from siku_core.contact_law import (
    G_AREA, G_AREA_I, G_AREA_J, G_K, G_MEFF, G_NX, G_NY, G_SIZE, G_WIDTH, J_DT, J_EI, J_EJ,
    J_HI, J_HJ, J_K, J_L0, J_MEFF, J_NU, J_S1X, J_S1Y, J_S2X, J_S2Y, J_SIZE, J_VAX, J_VAY,
    J_VBX, J_VBY, J_W,
)
from siku_plugins.contact_laws import (
    collision_evaluator, mohr_coulomb_evaluator, spring_evaluator,
)


@pytest.fixture
def fresh_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("SIKU_KERNEL_CACHE", str(tmp_path))
    monkeypatch.setattr(kernel_cache, "_MEMO", {})
    return tmp_path


def _collision_case(rng):
    g = rng.normal(0.0, 1.0, G_SIZE)
    g[[G_AREA, G_WIDTH, G_K, G_MEFF, G_AREA_I, G_AREA_J]] = 10.0 ** rng.uniform(-3, 9, 6)
    n = rng.normal(0.0, 1.0, 2)
    g[[G_NX, G_NY]] = n / np.linalg.norm(n)
    pars = np.array([rng.integers(2), rng.uniform(0, 0.9), rng.uniform(0, 10),
                     rng.uniform(0, 1) * rng.integers(2)], dtype=float)
    return g, pars, None


def _joint_g(rng):
    g = rng.normal(0.0, 1e4, J_SIZE)
    g[[J_S1X, J_S1Y, J_S2X, J_S2Y]] = rng.normal(0.0, 1.0, 4) * 10.0 ** rng.uniform(-3, 1)
    g[[J_L0, J_W]] = rng.uniform(1e3, 3e4, 2)
    g[[J_K, J_MEFF]] = 10.0 ** rng.uniform(4, 12, 2)
    g[[J_VAX, J_VAY, J_VBX, J_VBY]] = rng.normal(0.0, 1e-2, 4)
    g[[J_HI, J_HJ]] = rng.uniform(0.05, 10, 2)
    g[[J_EI, J_EJ]] = rng.uniform(2.5e8, 4e9, 2)
    g[J_NU] = 0.3
    g[J_DT] = 1.0
    return g


def _spring_case(rng):
    pars = np.array([10.0 ** rng.uniform(-5, -2), rng.uniform(0, 0.9), rng.uniform(0, 1)])
    return _joint_g(rng), pars, rng.uniform(0, 2) * pars[:1]


def _mc_case(rng):
    nseg = int(rng.integers(1, 16))
    pars = np.array([10.0 ** rng.uniform(4, 7) * rng.integers(2), 0.1, np.tan(0.3), nseg,
                     rng.uniform(0.5, 1), rng.uniform(0, 0.9)])
    return _joint_g(rng), pars, (rng.random(nseg) < 0.2).astype(float)


@pytest.mark.parametrize("ev, case", [
    (collision_evaluator, _collision_case),
    (spring_evaluator, _spring_case),
    (mohr_coulomb_evaluator, _mc_case),
])
def test_loops_call_a_copy_without_reference_counting(fresh_cache, ev, case):
    loops = kernel_cache.instantiate(contact_loops, ev)
    assert loops.__file__.startswith(str(fresh_cache))
    free = loops.evaluate
    assert free is not ev
    assert free.py_func.__code__ is ev.py_func.__code__  # the evaluator's own code
    assert free.targetoptions.get("_nrt") is False
    for chunk in (loops._joint_chunk, loops._collision_chunk, loops._collision_block):
        assert chunk.targetoptions.get("_nrt") is False
    rng = np.random.default_rng(5)
    broke = 0
    for _ in range(400):
        g, pars, hist = case(rng)
        outs = []
        for f in (ev, free):
            out = np.zeros(4)
            if hist is None:
                f(g, pars, out)
                outs.append(out)
            else:
                h = hist.copy()
                f(g, pars, h, out)
                outs.append(np.concatenate([out, h]))
        assert np.array_equal(outs[0], outs[1])
        broke += outs[0][3] != 0.0
    if hist is not None:  # both ways out of the joint laws were taken
        assert 0 < broke < 400


@pytest.fixture
def alloc_law():
    """The benchmark's law: the distributed spring through an allocated temporary."""
    from bench import allocating_evaluator

    return allocating_evaluator


def test_an_allocating_evaluator_is_used_as_it_is(fresh_cache, alloc_law):
    """It cannot be compiled without reference counting; its loop keeps reference counting
    (an ``_nrt=False`` loop cannot call it) and calls the evaluator itself."""
    ev = alloc_law.allocating_spring
    assert kernel_cache.without_nrt(ev) is None
    loops = kernel_cache.instantiate(contact_loops, ev)
    assert loops.evaluate is ev
    assert loops._joint_chunk.targetoptions.get("_nrt") is not False


def test_the_generated_file_is_the_header_and_the_template(fresh_cache):
    loops = kernel_cache.instantiate(contact_loops, spring_evaluator)
    text = open(loops.__file__).read()
    template = open(contact_loops.__file__).read()
    assert text.endswith(template)
    header = text[:-len(template)]
    assert "from siku_plugins.contact_laws.spring import spring_evaluator as evaluate" in header
    assert "NRT = False" in header and "CACHE = True" in header
    assert loops.CACHE is True and contact_loops.CACHE is False


def test_no_regular_expressions_over_source():
    import inspect

    src = inspect.getsource(kernel_cache)
    assert "import re\n" not in src and "re.sub" not in src


def test_the_generic_instance_is_the_template_run_with_the_evaluator_and_writes_nothing(
        fresh_cache):
    """An evaluator that no module holds by its name (a copy of the law's own): its instance
    is the template's file itself, run with the binding preset (the evaluator's own code,
    numba's cache off), and nothing is written to the cache directory. Making it compiles
    nothing of the loops (numba compiles them at their first call)."""
    import numba

    for ev in (spring_evaluator, collision_evaluator):
        anonymous = numba.njit(ev.py_func)
        assert not kernel_cache._importable(anonymous)
        loops = kernel_cache.instantiate(contact_loops, anonymous)
        assert loops.CACHE is False and loops.NRT is False
        assert loops.__file__ == contact_loops.__file__
        assert loops.evaluate.py_func.__code__ is ev.py_func.__code__
    assert not any(fresh_cache.iterdir())


@pytest.mark.slow  # compiles both loops for the generic instance, which is never cached
def test_an_evaluator_not_importable_by_name_gets_the_generic_instance(fresh_cache):
    """Not cached, and bit for bit what the cached instance computes: a pulled, jointed pack
    whose joints and collisions are evaluated by copies of the law's evaluators that no module
    holds."""
    import numba

    from siku_core.testing import contact_conformance as cc
    from siku_plugins.contact_laws import DistributedSpring

    states = []
    for anonymous in (False, True):
        sim = cc.law_simulation(DistributedSpring, {"tensile_strain": 2e-5},
                                packs=[cc.square_pack(10.0, 70.0, 3, 2, right="steady",
                                                      velocity=[0.05, 0.0])],
                                joints="auto", dt=0.05)
        cm = sim.contacts
        if anonymous:
            cm._jev = numba.njit(cm._jev.py_func)
            cm._cev = numba.njit(cm._cev.py_func)
            for ev in (cm._jev, cm._cev):
                assert not kernel_cache._importable(ev)
                loops = kernel_cache.instantiate(contact_loops, ev)
                assert loops.CACHE is False and loops.NRT is False
        sim.run(steps=40)
        states.append((sim.state.q.copy(), sim.state.V.copy(), cm.intact.copy()))
    assert not any(f.name.startswith("siku_generic") for f in fresh_cache.iterdir())
    for a, b in zip(*states):
        assert np.array_equal(a, b)
    assert not states[0][2].all()


def test_the_key_follows_the_modules_an_evaluator_calls_into():
    """The ridging law's evaluator calls ``collision_force`` of the collision law's module:
    that module's source is in the key (a change there once left a cached loop running the
    old force function, whose cap flag the ridging process never saw), and so are the
    geometry kernels the template calls, followed through the modules that call them."""
    import sys

    from siku_plugins.contact_laws import ridging

    deps = kernel_cache._dependencies(contact_loops, sys.modules[ridging.__name__])
    assert "siku_plugins.contact_laws.collision" in deps
    assert "siku_plugins.contact_laws.ridging" in deps
    assert "siku_core.geometry.clip" in deps
    assert not any(m.startswith("numba") for m in deps)
