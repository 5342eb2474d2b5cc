"""The output path's compiled kernels (diagnostics, joint metrics, stress, lat/lon) against
straightforward references, their independence of the thread count, and the default
schedules that keep writing a small share of a run (docs/explanation/outputs.md)."""
from __future__ import annotations

import math

import numba
import numpy as np
import pytest

from siku_core.contact.contact_frames import frame_point
from siku_core.diagnostics import element_diagnostics
from siku_core.geometry.quat import latlon_of, q_center, qrotate, xyz_to_latlon
from siku_core.contact.joint_metrics import joint_diagnostics, joint_strain_opening
from siku_core.run.schedule import (
    DEFAULT_DIAGNOSTICS, DEFAULT_DIAGNOSTICS_STEPS, DEFAULT_SNAPSHOT_STEPS, DEFAULT_SNAPSHOTS,
    StepInterval,
)


@pytest.fixture(scope="module")
def pack():
    """A pulled 60 x 50 pack (3000 elements, 5 900 joints: the kernels' parallel size) after
    a few steps, with some joints broken by hand."""
    from bench.scenes import bonded_text
    from siku_core.scene.scene_file import scene_from_text
    from siku_core.run.simulation import Simulation

    sim = Simulation(scene_from_text(bonded_text(3000, steps=20), "<pack>"), out=False)
    sim.run(5)
    cm = sim.contacts
    cm.intact[::7] = False
    return sim


def _reference_strain_opening(sim):
    cm, st, R = sim.contacts, sim.state, sim.radius
    n = cm.n_joints
    strain, opening = np.empty(n), np.empty(n)
    for k in range(n):
        i, j = cm.ji[k], cm.jj[k]
        a, b = cm.ends_i[k]
        A = frame_point(st.q[j], st.q[i], *cm.ends_j[k, 0], R)
        B = frame_point(st.q[j], st.q[i], *cm.ends_j[k, 1], R)
        s1, s2 = np.subtract(A, a), np.subtract(B, b)
        strain[k] = max(np.hypot(*s1), np.hypot(*s2)) / cm.L0[k]
        w = np.hypot(*(b - a))
        nrm = np.array([b[1] - a[1], -(b[0] - a[0])]) / w
        opening[k] = 0.5 * (s1 + s2) @ nrm
    return strain, opening


def test_joint_strain_and_opening_match_the_quaternion_reference(pack):
    cm, st = pack.contacts, pack.state
    strain, opening = joint_strain_opening(st.q, cm.ji, cm.jj, cm.ends_i, cm.ends_j, cm.L0,
                                           pack.radius)
    rs, ro = _reference_strain_opening(pack)
    # the rotation-matrix and quaternion paths differ by round-off of the 6.4e6 m radius:
    # |Δx| <~ 1e-16 R = 1e-9 m on displacements of the order of the pull
    scale = np.abs(ro).max()
    assert scale > 1e-6
    np.testing.assert_allclose(opening, ro, rtol=0, atol=1e-8)
    np.testing.assert_allclose(strain * cm.L0, rs * cm.L0, rtol=0, atol=1e-8)


def test_joint_diagnostics_match_their_definitions(pack):
    cm, st = pack.contacts, pack.state
    d = joint_diagnostics(st.q, cm.ji, cm.jj, cm.ends_i, cm.ends_j, cm.L0, cm.width, cm.intact,
                          cm.E, st.area, st.flags, pack.radius)
    strain, opening = _reference_strain_opening(pack)
    k = cm.intact
    sigma = 0.5 * (cm.E[cm.ji] + cm.E[cm.jj])[k] * opening[k] / cm.L0[k]
    lead = np.sum(np.clip(opening[~k], 0, None) * cm.width[~k])
    assert lead > 0
    assert d["lead_area"] == pytest.approx(lead, rel=1e-6)
    assert d["joint_stress_max"] == pytest.approx(max(sigma.max(), 0.0), rel=1e-6)
    assert d["joint_stress_min"] == pytest.approx(min(sigma.min(), 0.0), rel=1e-6, abs=1e-3)
    assert d["joint_strain_max"] == pytest.approx(strain[k].max(), rel=1e-6)


def test_element_sums_match_the_quaternion_reference(pack):
    st, R = pack.state, pack.radius
    d = element_diagnostics(st.q, st.V, st.w, st.m, st.I, R)
    p = np.zeros(3)
    L = np.zeros(3)
    for i in range(st.n):
        vg = qrotate(st.q[i], np.array([st.V[i, 0], st.V[i, 1], 0.0]))
        c = q_center(st.q[i])
        p += st.m[i] * vg
        L += st.m[i] * R * np.cross(c, vg) + st.I[i] * st.w[i] * c
    ke = np.sum(0.5 * st.m * (st.V ** 2).sum(1) + 0.5 * st.I * st.w ** 2)
    assert d["kinetic_energy"] == pytest.approx(ke, rel=1e-12)
    pscale = np.sum(st.m * np.hypot(*st.V.T))
    np.testing.assert_allclose([d[f"momentum_{a}"] for a in "xyz"], p, rtol=0,
                               atol=1e-12 * pscale)
    np.testing.assert_allclose([d[f"angular_momentum_{a}"] for a in "xyz"], L, rtol=0,
                               atol=1e-12 * pscale * R)
    assert d["max_speed"] == np.hypot(*st.V.T).max()


def test_latlon_of_is_the_elementwise_formula(pack):
    lat, lon = latlon_of(pack.state.q)
    ref = np.array([xyz_to_latlon(q_center(q)) for q in pack.state.q])
    assert np.array_equal(lat, ref[:, 0]) and np.array_equal(lon, ref[:, 1])


def test_diagnostics_and_fields_are_the_same_bit_for_bit_on_one_and_two_threads(pack):
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("one numba thread only")
    before = numba.get_num_threads()
    got = []
    try:
        for t in (1, 2):
            numba.set_num_threads(t)
            got.append((pack.diagnostics(), pack.element_fields()))
    finally:
        numba.set_num_threads(before)
    (d1, f1), (d2, f2) = got
    assert d1 == d2
    assert all(np.array_equal(f1[k], f2[k]) for k in f1)


@pytest.mark.parametrize("n_steps", [10, 100, 1000, 10_000, 123_457])
def test_default_schedules_are_about_the_stated_counts_and_never_closer_than_stated(n_steps):
    for count, least in ((DEFAULT_SNAPSHOTS, DEFAULT_SNAPSHOT_STEPS),
                         (DEFAULT_DIAGNOSTICS, DEFAULT_DIAGNOSTICS_STEPS)):
        s = StepInterval.from_seconds(None, 1.0, n_steps, count, least)
        make = StepInterval.snapshots if count == DEFAULT_SNAPSHOTS else StepInterval.diagnostics
        assert make(None, 1.0, n_steps) == s
        assert s.every >= least
        due = [k for k in range(n_steps + 1) if s.due(k, n_steps)]
        assert due[0] == 0 and due[-1] == n_steps
        assert len(due) <= count + 2
        if n_steps >= count * least:  # long runs: the count, not the spacing, decides
            assert len(due) >= count
        assert math.ceil(n_steps / s.every) + 1 >= len(due)
