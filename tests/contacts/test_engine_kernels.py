"""The engine's parallel contact kernels (``siku_core.contact.contact_forces``, fast path).

* Results do not depend on the number of threads or on how loops are cut into chunks: every
  contact writes its own row and every element sums its own contacts in a fixed order, so a
  run on one thread and on two threads gives the same state bit for bit (the restart tests
  need bit-for-bit reproducibility too).
* The separating-axis test that skips the clipping (``apart``: an edge line of either polygon
  has the other on its outer side or on it) agrees with the clipping: pairs it calls apart have
  no overlap area beyond round-off, pairs it does not call apart do overlap (random polygons,
  touching squares with and without round-off noise, gaps down to 1e-12 of the size), and a run
  with it gives the same state bit for bit as a run without it.
* The kernels agree with the serial reference loops (``reference_loops.py``: ``joint_loop``,
  ``collision_loop``, the
  previous implementation, quaternion rotations per contact) to round-off, contact for contact.
"""
from __future__ import annotations

import numba
import numpy as np
import pytest
from numba import njit, prange

import siku_core.parallel as parallel
from reference_loops import collision_loop, joint_loop
from siku_core.contact.contact_frames import rotation_matrices, rotations_within
from siku_core.geometry.clip import (
    REL_TOL,
    apart,
    apart_within,
    make_overlap_scratch,
    overlap,
    overlap_elements,
    overlap_scratch,
    polygon_area_centroid,
    separating_edge,
)
from siku_core.run.simulation import Simulation
from siku_core.testing import switches
from siku_core.testing.contact_conformance import contact_scene, square_pack

DYN = ("q", "V", "w")


def pulled_pack(law="distributed_spring", steps=30, nx=12, ny=8, jitter=0.2, gap=0.0,
                touching="contact"):
    """A jittered jointed pack at 70°N, west column static, east column pulled north-east at
    2 m/s: joints stretch and (distributed_spring) break near the handle, and broken and
    compressed neighbours collide. ``touching = "contact"`` (not the default): the neighbours
    that touch to round-off are contacts too, so every path of the collision loop runs, and
    the serial reference loops (which know no other rule) apply."""
    params = {"distributed_spring": {"tensile_strain": 1e-4, "damage_onset": 0.5},
              "mohr_coulomb": {"break_share": 0.8}, "collision": {}}[law]
    pack = square_pack(10.0, 70.0, nx, ny, 2000.0, jitter=jitter, gap=gap, seed=3,
                       left="static", right="steady", right_velocity=[2.0, 0.7])
    return contact_scene(law, params, packs=[pack], dt=0.05, steps=steps,
                         joints="none" if law == "collision" else None, touching=touching)


@pytest.fixture
def many_chunks(monkeypatch):
    """Cut even small loops into many chunks (the default runs them on one thread)."""
    monkeypatch.setattr(parallel, "PARALLEL_MIN", 0)
    monkeypatch.setattr(parallel, "CHUNK_MIN", 7)


def run_with(scene, threads, steps):
    old = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        sim = Simulation(scene, out=False, progress=False)
        sim.run(steps)
    finally:
        numba.set_num_threads(old)
    return sim


@pytest.mark.skipif(numba.config.NUMBA_NUM_THREADS < 2, reason="needs two numba threads")
@pytest.mark.parametrize("law", ["distributed_spring", "mohr_coulomb", "collision"])
def test_one_and_two_threads_give_identical_states(many_chunks, law):
    sc = pulled_pack(law)
    one = run_with(sc, 1, 30)
    two = run_with(sc, 2, 30)
    old = numba.get_num_threads()
    numba.set_num_threads(2)
    try:
        assert parallel.chunks(1000) > 1  # the loops really were cut into chunks on two threads
    finally:
        numba.set_num_threads(old)
    cm1, cm2 = one.contacts, two.contacts
    assert cm1.n_overlap > 0
    if law != "collision":
        assert 0 < cm1.n_intact <= cm1.n_joints
    for k in DYN:
        a, b = getattr(one.state, k), getattr(two.state, k)
        assert np.array_equal(a, b), f"{k} differs by up to {np.abs(a - b).max():.3e}"
    assert np.array_equal(one.state.F, two.state.F) and np.array_equal(one.state.T, two.state.T)
    assert np.array_equal(cm1.intact, cm2.intact) and np.array_equal(cm1.hist, cm2.hist)
    assert cm1.n_overlap == cm2.n_overlap and cm1.n_broken_total == cm2.n_broken_total


def test_chunking_does_not_change_results(monkeypatch):
    """One chunk (serial) against many chunks on the same thread count."""
    sc = pulled_pack("distributed_spring", nx=10, ny=6)
    serial = run_with(sc, 1, 25)
    monkeypatch.setattr(parallel, "PARALLEL_MIN", 0)
    monkeypatch.setattr(parallel, "CHUNK_MIN", 5)
    monkeypatch.setattr(parallel, "threads", lambda: 3)
    chunked = run_with(sc, 1, 25)
    for k in DYN:
        assert np.array_equal(getattr(serial.state, k), getattr(chunked.state, k)), k


# ------------------------------------------------------------------ separation test
def _square(c, s, rot=0.0):
    a = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=float) * s / 2
    r = np.array([[np.cos(rot), -np.sin(rot)], [np.sin(rot), np.cos(rot)]])
    return np.ascontiguousarray(a @ r.T + np.asarray(c, dtype=float))


def _convex(rng, n, c, r):
    ang = np.sort(rng.uniform(0, 2 * np.pi, n))
    return np.ascontiguousarray(np.stack([c[0] + r * np.cos(ang), c[1] + r * np.sin(ang)], 1))


def _cases(seed=0, n=4000):
    rng = np.random.default_rng(seed)
    s = 2e4
    for _ in range(n):
        kind = rng.integers(4)
        if kind == 0:  # random convex polygons, anywhere
            yield (_convex(rng, rng.integers(3, 9), (0, 0), s),
                   _convex(rng, rng.integers(3, 9), rng.normal(0, s, 2), s))
        elif kind == 1:  # edge- or corner-touching squares, with round-off noise
            off = [(s, 0), (0, s), (s, s), (-s, s)][rng.integers(4)]
            noise = rng.normal(0, 1e-9 * s, (4, 2)) * rng.integers(0, 2)
            yield _square((0, 0), s), _square(off, s) + noise
        elif kind == 2:  # tilted neighbours, overlapping or not
            yield (_square((0, 0), s, rng.uniform(0, 0.1)),
                   _square((s * rng.uniform(0.9, 1.1), s * rng.uniform(-0.2, 0.2)), s,
                           rng.uniform(0, 0.1)))
        else:  # a gap (or overlap) from 1e-12 to 1e-2 of the size
            gap = 10.0 ** rng.uniform(-12, -2) * s * rng.choice([-1, 1])
            yield _square((0, 0), s), _square((s + gap, 0), s)


def test_apart_is_the_separating_axis_test_of_the_clip():
    """``apart`` implies no overlap area: the clip's points carry an error of a few ``u big``
    (``u = 2**-53``, ``big`` the largest coordinate), so a sliver the test misses is at most
    that wide and ``2 sqrt(2) big`` long: area below ``32 u big²``. Not apart implies an
    overlap (the interiors intersect): the clip finds area. Touching squares (shared edge or
    corner, exact coordinates) are apart."""
    u = np.finfo(float).eps / 2
    n_apart = 0
    for p1, p2 in _cases(seed=2, n=6000):
        big = max(np.abs(p1).max(), np.abs(p2).max())
        a = overlap(p1, p2)[0]
        if apart(p1, p2):
            n_apart += 1
            assert a <= 32 * u * big * big
        else:
            assert a > 0.0
    s = 2e4
    for off in [(s, 0), (0, s), (s, s), (-s, s), (-s, -s)]:
        assert apart(_square((0, 0), s), _square(off, s))
        assert apart(_square(off, s), _square((0, 0), s))
    assert not apart(_square((0, 0), s), _square((s * (1 - 1e-9), 0), s))
    assert n_apart > 2000


def test_the_hint_changes_which_edge_not_whether():
    """``separating_edge`` finds an edge for exactly the pairs ``apart`` finds apart, whatever
    edge it tries first; the edge it returns separates (the test with it alone passes)."""
    n_found = 0
    for p1, p2 in _cases(seed=5, n=1500):
        n = len(p1) + len(p2)
        exact = apart(p1, p2)
        for hint in (-1, 0, n - 1, n // 2, n + 3):
            e = separating_edge(p1, p2, 0.0, hint)
            assert (e >= 0) == exact
            if e >= 0:
                n_found += 1
                assert separating_edge(p1, p2, 0.0, e) == e
    assert n_found > 1000


def test_apart_within_the_margin_means_touching_for_the_clip():
    """``contact.touching = "ignore"``: with the margin ``REL_TOL s / 3`` (``s`` the largest
    coordinate of polygon 1) a pair found apart overlaps by at most ``2 sqrt(2)/3 REL_TOL
    big²`` (a strip of that width inside one polygon, at most its diameter long), below the
    clip's touching area ``REL_TOL big²``, so the engine's clip would drop it too; and every
    pair the exact test finds apart is found apart with a margin."""
    xy, tag = make_overlap_scratch(8, 8)
    n_margin = n_dropped = 0
    for p1, p2 in _cases(seed=6, n=6000):
        big = max(np.abs(p1).max(), np.abs(p2).max())
        margin = REL_TOL * np.abs(p1).max() / 3.0
        within = apart_within(p1, p2, margin)
        if apart(p1, p2):
            assert within
        elif within:
            n_margin += 1
            a = overlap(p1, p2)[0]
            assert a <= 2 * np.sqrt(2) / 3 * REL_TOL * big * big * (1 + 1e-6)
            _, c1x, c1y = polygon_area_centroid(p1)
            q1 = np.ascontiguousarray(p1 - [c1x, c1y])
            q2 = np.ascontiguousarray(p2 - [c1x, c1y])
            kept = overlap_elements(q1, q2, xy, tag, 1.0, 0.0)[0]
            dropped = overlap_elements(q1, q2, xy, tag, 1.0, 0.0, True)
            assert dropped[0] == 0.0
            # ncross -1: touching and dropped (the engine then skips the test next time); 0:
            # no overlap at all
            assert dropped[3] == (-1 if kept > 0.0 else 0)
            n_dropped += kept > 0.0
    assert n_dropped > 200
    assert n_margin > 200  # round-off slivers; overlaps of 1e-12 ... 3e-10 of the size


def test_lazy_clip_gives_the_same_overlap():
    xy, tag = make_overlap_scratch(8, 8)
    for p1, p2 in _cases(seed=1, n=2000):
        full = overlap(p1, p2)
        lazy = overlap_scratch(p1, p2, xy, tag, True)
        if full[0] > 0.0:
            assert tuple(full) == tuple(lazy)
        else:
            assert lazy[0] == full[0]


def test_element_clip_is_the_lazy_clip_with_the_centre_line_normal():
    """``overlap_elements`` (the engine's clip: polygon 1 centred at the origin, polygon 2's
    centre given) returns the lazy clip's area, centroid and crossing points bit for bit; its
    normal is the chord normal where the boundaries cross twice and otherwise runs along the
    given centre line. With the given centre at polygon 2's centroid the two normals agree to
    the round-off of the centroids (a few ``u big``) over the centroids' distance: below 1e-12
    for these polygons, whose centroids are at least 0.02 ``big`` apart where they overlap."""
    xy, tag = make_overlap_scratch(8, 8)
    n_fallback = n_chord = 0
    for p1, p2 in _cases(seed=4, n=3000):
        _, c1x, c1y = polygon_area_centroid(p1)
        p1 = np.ascontiguousarray(p1 - [c1x, c1y])
        p2 = np.ascontiguousarray(p2 - [c1x, c1y])
        _, c2x, c2y = polygon_area_centroid(p2)
        lazy = overlap_scratch(p1, p2, xy, tag, True)
        el = overlap_elements(p1, p2, xy, tag, c2x, c2y)
        assert el[:8] == lazy[:8]
        if lazy[0] <= 0.0:
            continue
        if lazy[3] == 2:
            n_chord += 1
            assert el[8:] == lazy[8:]
        else:
            n_fallback += 1
            assert np.allclose(el[8:], lazy[8:], rtol=0, atol=1e-12)
            # a centre elsewhere turns the fallback normal with it
            other = overlap_elements(p1, p2, xy, tag, c2x - 0.3 * c2y, c2y + 0.3 * c2x)
            d = np.array([c2x - 0.3 * c2y, c2y + 0.3 * c2x])
            assert np.allclose(other[8:], d / np.linalg.norm(d), rtol=0, atol=1e-15)
    assert n_chord > 300 and n_fallback > 100


@pytest.mark.parametrize("touching", ["contact", "ignore"])
def test_runs_with_and_without_the_separation_test_are_identical(monkeypatch, touching):
    # a gapped, jittered broken pack: many candidate pairs are apart, some collide
    sc = pulled_pack("distributed_spring", gap=0.002, jitter=0.25, touching=touching)
    with_test = Simulation(sc, out=False, progress=False).run(30)
    monkeypatch.setattr(switches, "pretest", False)
    without = Simulation(sc, out=False, progress=False).run(30)
    assert with_test.contacts.n_overlap == without.contacts.n_overlap
    for k in DYN:
        assert np.array_equal(getattr(with_test.state, k), getattr(without.state, k)), k


def test_touching_pairs_skip_the_separation_test_and_change_nothing(monkeypatch):
    """Under ``"ignore"`` a pair the clip found touching (dropped: ``on = 2``) goes straight to
    the clip at the next evaluation; the run is the same bit for bit as one without the
    separation test, and such pairs occur (jointed neighbours of the unjittered pack)."""
    sc = pulled_pack("distributed_spring", touching="ignore")
    sim = Simulation(sc, out=False, progress=False)
    seen = 0
    for _ in range(30):
        sim.step()
        seen = max(seen, int(np.sum(sim.contacts.pair_active == 2)))
    assert seen > 10
    monkeypatch.setattr(switches, "pretest", False)
    without = Simulation(sc, out=False, progress=False).run(30)
    assert sim.contacts.n_overlap == without.contacts.n_overlap
    for k in DYN:
        assert np.array_equal(getattr(sim.state, k), getattr(without.state, k)), k


# ------------------------------------------------------------------ against the reference loops
@pytest.mark.parametrize("law", ["distributed_spring", "mohr_coulomb"])
def test_kernels_match_the_serial_reference_loops(law):
    sim = Simulation(pulled_pack(law, jitter=0.3), out=False, progress=False)
    sim.run(20)  # a deformed state with stretched, broken and colliding contacts
    st, cm, law_ = sim.state, sim.contacts, sim.contacts.law
    q, V, w = st.q.copy(), st.V.copy(), st.w.copy()
    F, T = np.zeros_like(st.F), np.zeros_like(st.T)
    cm.add(0.0, q, V, w, F, T, False)
    Fr, Tr = np.zeros_like(F), np.zeros_like(T)
    intact = cm.intact.copy()
    hist = cm.hist.copy()
    broke = joint_loop(law_.joint_evaluator, cm._jpars, q, V, w, cm.minv, st.thickness, cm.E,
                       cm.nu, cm.ji, cm.jj, cm.ends_i, cm.ends_j, cm.L0, cm.width, intact, hist,
                       sim.radius, sim.dt, False, Fr, Tr)
    n = collision_loop(law_.collision_evaluator, cm._cpars, q, V, w, cm.minv, st.thickness,
                       cm.E, st.area, st.vert_offsets, st.verts, cm.pairs, sim.radius, Fr, Tr,
                       cm.pface, cm.scale)
    assert broke == 0 and n == int((cm.pair_active == 1).sum()) > 0
    assert (cm.pface[:, 0] >= 0).sum() >= len(cm.ji)  # jointed pairs take the face path
    # joint displacements are differences of km-sized coordinates projected from another
    # frame: one ulp of the planet radius (1.4e-9 m) times a joint stiffness K w (~2e9 N/m) is
    # a few N, ~1e-7 of the largest force here; the two implementations round differently
    fscale = np.abs(Fr).max()
    tscale = np.abs(Tr).max()
    assert np.allclose(F, Fr, rtol=0, atol=1e-6 * fscale), np.abs(F - Fr).max() / fscale
    assert np.allclose(T, Tr, rtol=0, atol=1e-6 * tscale), np.abs(T - Tr).max() / tscale


@njit(parallel=True)
def _claim_all(nch, nt, seen):
    counter = np.zeros(1, dtype=np.int64)
    for t in prange(nt):
        while True:
            c = parallel.claim(counter)
            if c >= nch:
                break
            seen[c] += 1


@pytest.mark.parametrize("nch, nt", [(1, 1), (7, 2), (64, 2), (64, 5)])
def test_claimed_chunks_are_each_run_exactly_once(nch, nt):
    """The contact loops' dynamic schedule: whatever the tasks and threads, every chunk is
    claimed by exactly one task."""
    seen = np.zeros(nch, dtype=np.int64)
    _claim_all(nch, nt, seen)
    assert np.array_equal(seen, np.ones(nch, dtype=np.int64))


@pytest.mark.parametrize("nch", [1, 4])
def test_rotations_within_is_rotation_matrices_and_the_skin_check(nch):
    rng = np.random.default_rng(nch)
    n = 300
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1)[:, None]
    ref = rng.normal(size=(n, 3))
    ref /= np.linalg.norm(ref, axis=1)[:, None]
    rm = np.empty((n, 3, 3))
    rotation_matrices(q, rm, nch)
    d2 = ((rm[:, :, 2] - ref) ** 2).sum(axis=1)  # squared chords between the centres
    lim2 = d2.max()
    rm2 = np.full((n, 3, 3), np.nan)
    assert rotations_within(q, rm2, nch, ref, lim2)
    assert np.array_equal(rm2, rm)  # the same matrices, bit for bit
    assert not rotations_within(q, rm2, nch, ref, np.nextafter(lim2, 0.0))
    ref2 = ref.copy()
    ref2[n - 1, 2] = np.nan
    assert not rotations_within(q, rm2, nch, ref2, np.inf)
