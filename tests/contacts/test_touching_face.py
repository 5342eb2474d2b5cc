"""The touching face of jointed neighbours (``siku_core.geometry.face``) against the clip.

* Fuzzed (hypothesis): a convex polygon and its mirror image across one edge, moved off the
  edge by a normal offset from 1e-14 to 1e-3 of the polygon's size (either way), slid along it
  and turned by up to 1e-9 rad. Whenever :func:`touching_face` accepts the pair, the clip calls
  the overlap touching too (area at most ``REL_TOL big²``: the proof in the module docstring),
  the two areas agree to the round-off of the vertex coordinates (a few ``eps s L`` for a
  polygon of scale ``s`` and an edge of length ``L``), the contact point is the middle of the
  edges' common stretch and the width its length. A real overlap is never accepted; a pair the
  edge's line separates is apart.
* In the engine: on a bonded pack the face path finds the same contacts as the clip, and the
  contact point of a touching face sits at the middle of the joint.
"""
from __future__ import annotations

import math

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from siku_core.geometry.clip import (
    REL_TOL,
    make_overlap_scratch,
    overlap_elements,
    project_partner,
)
from siku_core.geometry.clip import polygon_area_centroid as centroid
from siku_core.geometry.face import edge_table, joint_edges, touching_face, touching_face_u
from siku_core.run.simulation import Simulation
from siku_core.testing import switches
from siku_core.testing.contact_conformance import contact_scene, square_pack

EPS = np.finfo(float).eps


def _mirror_pair(angles, radius, s):
    """A convex polygon on a circle and its mirror image across edge ``s`` (counter-clockwise,
    its edge ``k`` running from ``P[s + 1]`` to ``P[s]``)."""
    th = np.sort(np.asarray(angles))
    P = np.c_[radius * np.cos(th), radius * np.sin(th)]
    n = len(P)
    s1 = (s + 1) % n
    u = (P[s1] - P[s]) / np.linalg.norm(P[s1] - P[s])
    nrm = np.array([-u[1], u[0]])  # into P
    Q = (P - 2.0 * ((P - P[s]) @ nrm)[:, None] * nrm)[::-1].copy()
    k = (n - 1 - s1) % n
    return P, Q, k, u, nrm


def _moved(Q, u, nrm, pivot, depth, slide, turn):
    c, s = math.cos(turn), math.sin(turn)
    rot = np.array([[c, -s], [s, c]])
    return (Q + depth * nrm + slide * u - pivot) @ rot.T + pivot


polygons = st.integers(3, 8).flatmap(
    lambda n: st.lists(st.floats(0.0, 2 * math.pi), min_size=n, max_size=n).filter(
        lambda a: min(np.diff(np.r_[np.sort(a), min(a) + 2 * math.pi])) > 0.15))


@settings(max_examples=400, deadline=None)
@given(angles=polygons, lg_radius=st.floats(2.0, 4.5), edge=st.integers(0, 7),
       lg_depth=st.floats(-14.0, -3.0), inward=st.booleans(), slide=st.floats(-0.3, 0.3),
       lg_turn=st.floats(-16.0, -9.0), turn_sign=st.sampled_from([-1.0, 0.0, 1.0]),
       where=st.floats(0.0, 1.0))
def test_an_accepted_face_is_the_clips_touching_overlap(angles, lg_radius, edge, lg_depth,
                                                       inward, slide, lg_turn, turn_sign, where):
    P, Q, k, u, nrm = _mirror_pair(angles, 10.0 ** lg_radius, edge % len(angles))
    n = len(P)
    s = edge % n
    s1 = (s + 1) % n
    scale = np.abs(P).max()
    L = float(np.linalg.norm(P[s1] - P[s]))
    depth = (1.0 if inward else -1.0) * 10.0 ** lg_depth * scale
    Q = _moved(Q, u, nrm, P[s] + where * (P[s1] - P[s]), depth, slide * L,
               turn_sign * 10.0 ** lg_turn)
    k1 = (k + 1) % n
    a, px, py, width = touching_face(P, s, Q[k, 0], Q[k, 1], Q[k1, 0], Q[k1, 1], scale)
    xy, tag = make_overlap_scratch(n, n)
    _, qx, qy = centroid(Q)
    ref = overlap_elements(P, Q, xy, tag, qx, qy)
    big = max(np.abs(P).max(), np.abs(Q).max())
    if ref[0] > REL_TOL * big * big:
        assert a < 0.0  # a real overlap goes to the clip
    if a < 0.0:
        return
    # accepted: the clip calls it touching (or finds nothing), with the same area
    assert ref[0] <= REL_TOL * big * big
    assert ref[3] == 0
    assert abs(a - ref[0]) <= 8.0 * EPS * scale * L
    f = (Q[k1] - Q[k])
    deepest = max(f[0] * (v[1] - Q[k, 1]) - f[1] * (v[0] - Q[k, 0]) for v in P)
    if deepest < 0.0:
        assert a == 0.0  # the joint edge's line separates them
    if a > 0.0:
        # the middle of the common stretch of the two edges, and its length
        t = [(Q[k1] - P[s]) @ (P[s1] - P[s]) / L**2, (Q[k] - P[s]) @ (P[s1] - P[s]) / L**2]
        x0, x1 = max(0.0, t[0]), min(1.0, t[1])
        mid = P[s] + 0.5 * (x0 + x1) * (P[s1] - P[s])
        assert math.hypot(px - mid[0], py - mid[1]) <= 4.0 * EPS * scale
        assert abs(width - (x1 - x0) * L) <= 4.0 * EPS * scale


# lists of up to four polygons, each drawn by filtering angle sets (gaps > 0.15 rad): the
# filtering is the strategy's own, so hypothesis's filter_too_much health check is no finding
@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.filter_too_much])
@given(polys=st.lists(polygons, min_size=2, max_size=4), lg_radius=st.floats(2.0, 4.5),
       pick=st.integers(0, 3), edge=st.integers(0, 7), lg_depth=st.floats(-14.0, -10.0))
def test_the_engines_edge_table_gives_the_faces_of_its_own_edges(polys, lg_radius, pick, edge,
                                                                 lg_depth):
    # the engine takes |u|², 1/|u|² and |u| of the joint's edge from a table of every
    # element's edges (row offsets[e] + s); irregular polygons, so that a wrong row shows
    P = [_mirror_pair(a, 10.0 ** lg_radius, 0)[0] for a in polys]
    offsets = np.r_[0, np.cumsum([len(p) for p in P])]
    table = edge_table(offsets, np.concatenate(P))
    e = pick % len(P)
    s = edge % len(P[e])
    _, Q, k, u, nrm = _mirror_pair(polys[e], 10.0 ** lg_radius, s)
    Q = Q + 10.0 ** lg_depth * np.abs(P[e]).max() * nrm  # pressed in by a hair: a face
    k1 = (k + 1) % len(Q)
    args = (P[e], s, Q[k, 0], Q[k, 1], Q[k1, 0], Q[k1, 1], np.abs(P[e]).max())
    ref = touching_face(*args)
    assert ref[0] > 0.0
    assert touching_face_u(*args, *table[offsets[e] + s]) == ref


def test_a_real_overlap_and_a_gap_are_not_taken_for_a_face():
    P, Q, k, u, nrm = _mirror_pair([0.3, 1.9, 3.6, 5.0], 1.0e4, 1)
    k1 = (k + 1) % 4
    for depth, expect in ((1e-6, "clip"), (-1e-6, "apart"), (1e-15, "face"), (0.0, "face")):
        q = Q + depth * 1.0e4 * nrm
        a, *_ = touching_face(P, 1, q[k, 0], q[k, 1], q[k1, 0], q[k1, 1], 1.0e4)
        got = "clip" if a < 0 else "apart" if a == 0 else "face"
        if depth == 0.0:  # exactly on the line: no area either way
            assert got in ("face", "apart")
        else:
            assert got == expect, (depth, a)


def test_joint_edges_name_the_edges_of_the_joint():
    P, Q, k, *_ = _mirror_pair([0.3, 1.9, 3.6, 5.0], 1.0e4, 2)
    verts = np.concatenate([P, Q])
    offsets = np.array([0, 4, 8])
    ends_i = np.array([[P[2], P[3]]])
    ends_j = ends_i.copy()  # the same plane here
    e = joint_edges(offsets, verts, np.array([0]), np.array([1]), ends_i, ends_j)
    assert e.tolist() == [[2, k]]


def _forces(sim, face_path):
    st_, cm = sim.state, sim.contacts
    switches.face_path = face_path
    try:
        cm.pface = cm._faces(cm.pairs)
    finally:
        switches.face_path = True
    cm.pair_active[:] = 0
    F, T = np.zeros_like(st_.F), np.zeros_like(st_.T)
    cm.add(0.0, st_.q.copy(), st_.V.copy(), st_.w.copy(), F, T, False)
    return F, T, cm.pair_active.copy(), cm.pair_rows.copy()


def test_the_engine_puts_a_touching_face_at_the_middle_of_its_joint():
    # a jointed pack at 70°N, east column pulled north-east: stretched, sheared and touching
    # joints (the packs of test_engine_kernels, unjittered); touching faces are contacts
    # under touching = "contact" only
    pack = square_pack(10.0, 70.0, 12, 8, 2000.0, jitter=0.0, seed=3, left="static",
                       right="steady", right_velocity=[2.0, 0.7])
    sc = contact_scene("distributed_spring", {"tensile_strain": 1e-4, "damage_onset": 0.5},
                       packs=[pack], dt=0.05, steps=10, touching="contact")
    sim = Simulation(sc, out=False, progress=False)
    sim.run(10)
    cm = sim.contacts
    on0 = _forces(sim, False)[2]
    on1, out1 = _forces(sim, True)[2:]
    face = cm._faces(cm.pairs)[:, 0] >= 0
    assert face.sum() > 0
    # the same contacts (the clip calls every face the path accepts touching)
    assert (on0 == on1).all() and (on1[face] == 1).sum() > 0
    # the contact point of every face the path accepts: the middle of the two edges' common
    # stretch, as touching_face finds it on the partner projected as the engine projects it
    st_ = sim.state
    off, verts = st_.vert_offsets, st_.verts
    pfc = cm._faces(cm.pairs)
    accepted = 0
    for k in np.flatnonzero(face & (on1 == 1)):
        i, j = cm.pairs[k]
        pi = verts[off[i]:off[i + 1]]
        pj = np.empty((off[j + 1] - off[j], 2))
        project_partner(st_.q[i], st_.q[j], verts[off[j]:off[j + 1]], sim.radius, pj)
        fj, fj1 = pfc[k, 1], (pfc[k, 1] + 1) % len(pj)
        a, px, py, _ = touching_face(pi, pfc[k, 0], pj[fj, 0], pj[fj, 1], pj[fj1, 0],
                                     pj[fj1, 1], cm.scale[i])
        if a > 0.0:
            accepted += 1
            assert np.hypot(*(out1[k, 6:8] - (px, py))) <= 1e-9 * cm.scale[i]
            # on the joint, between its ends (the means of the matched vertices, which coincide
            # in this unjittered pack to round-off of the projection)
            n = np.flatnonzero((np.minimum(cm.ji, cm.jj) == min(i, j))
                               & (np.maximum(cm.ji, cm.jj) == max(i, j)))[0]
            e0, e1 = cm.ends_i[n] if cm.ji[n] == i else cm.ends_j[n]
            t = (np.array([px, py]) - e0) @ (e1 - e0) / ((e1 - e0) @ (e1 - e0))
            d = e1 - e0
            off_line = abs(d[0] * (py - e0[1]) - d[1] * (px - e0[0])) / np.hypot(*d)
            assert -1e-6 <= t <= 1.0 + 1e-6 and off_line <= 1e-6 * cm.width[n]
    assert accepted > 0
