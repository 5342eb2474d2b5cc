"""Element sources as a plugin kind, and the bonded floe sources (``floe``, ``floe_field``).

A floe is a convex outline tiled by the Voronoi cells of Poisson-disc seeds clipped to it, so:

* the elements' areas add up to the outline's area: exactly in the plane; on the sphere each
  element is re-projected into its own tangent plane, which changes an area by ``O((r/R)²)``
  (``r`` the element's distance from the floe centre): below 1e-8 for the 1 km floes here;
* every pair of cells that shares a Voronoi edge is bonded (``joints = "auto"``), and no other
  pair: the joint count equals the number of interior edges of the planar tiling;
* the mean element area is ``D²`` (Poisson-disc spacing ``0.78 D``: a Bridson packing holds one
  seed per ``1.64 r²``), to the packing's scatter and the cut cells along the outline (10 %).
"""
from __future__ import annotations

import math
import types

import numpy as np
import pytest

from siku_core import Simulation, hookimpl
from siku_core.errors import SceneError
from siku_core.interfaces import ElementSource, ElementSpec
from siku_core.plugins import register_module, unregister_module
from siku_core.scene.scene_file import scene_from_text
from siku_plugins.floes import FloeField, fill_outline, outline_polygon, polygon_area

BASE = """
[time]
dt = 0.001
duration = 0.002
[elements]
thickness = 1.0
"""


def build(sources: str, contact: bool = True) -> Simulation:
    text = BASE + sources + ('\n[contact]\nlaw = "bonded_particle"\n' if contact else "")
    return Simulation(scene_from_text(text, "<sources test>"), out=False, progress=False)


def floe(**params) -> str:
    inner = ", ".join(f"{k} = {v!r}" if not isinstance(v, str) else f'{k} = "{v}"'
                      for k, v in params.items())
    return f'[[elements.source]]\nname = "floe"\nparams = {{ {inner} }}\n'


def interior_edges(cells, tol) -> int:
    """Edges shared by two cells of a planar tiling (matched by their end points)."""
    keys = {}
    for c in cells:
        for k in range(len(c)):
            a, b = c[k], c[(k + 1) % len(c)]
            key = tuple(sorted((tuple(np.round(a / tol)), tuple(np.round(b / tol)))))
            keys[key] = keys.get(key, 0) + 1
    return sum(1 for v in keys.values() if v == 2)


@pytest.mark.parametrize(("outline", "lat", "lon"), [
    ("rectangle", 75.0, 170.0), ("disc", 0.0, 179.99), ("ellipse", 89.99, 0.0)])
def test_floe_tiles_its_outline_and_bonds_every_neighbour(outline, lat, lon):
    D = 60.0
    sim = build(floe(outline=outline, center=[lon, lat], length=1000.0, width=600.0,
                     angle=25.0, element_size=D, seed=3))
    st = sim.state
    planar = outline_polygon(outline, 1000.0, 600.0, 25.0, D)
    assert st.area.sum() == pytest.approx(abs(polygon_area(planar)), rel=1e-8)
    assert st.area.mean() == pytest.approx(D * D, rel=0.10)
    assert (st.floe == 0).all()
    cells = fill_outline(planar, D, np.random.default_rng(3))
    assert len(cells) == st.n
    assert sim.contacts.n_joints == interior_edges(cells, 1e-6 * D)
    assert not sim.contacts.rejected


def test_floe_is_reproducible_from_its_seed_and_the_scene_seed():
    a = build(floe(element_size=50.0, seed=1), contact=False).state
    b = build(floe(element_size=50.0, seed=1), contact=False).state
    c = build(floe(element_size=50.0, seed=2), contact=False).state
    assert np.array_equal(a.verts, b.verts)
    assert a.n != c.n or not np.array_equal(a.verts, c.verts)
    # seed = -1: the scene's [run] seed
    text = BASE + floe(element_size=50.0) + "[run]\nseed = 1\n"
    d = Simulation(scene_from_text(text), out=False, progress=False).state
    assert np.array_equal(a.verts, d.verts)


def test_floe_from_a_lonlat_polygon_and_a_refused_concave_one():
    sq = [[10.0, 70.0], [10.02, 70.0], [10.02, 70.005], [10.01, 70.008], [10.0, 70.005]]
    sim = build(f'[[elements.source]]\nname = "floe"\nparams = {{ outline = "polygon", '
                f'vertices = {sq!r}, element_size = 40.0 }}\n', contact=False)
    assert sim.state.n > 20
    concave = [[10.0, 70.0], [10.02, 70.0], [10.01, 70.002], [10.02, 70.005], [10.0, 70.005]]
    with pytest.raises(SceneError, match=r"elements.source\[0\].*convex"):
        build(f'[[elements.source]]\nname = "floe"\nparams = {{ outline = "polygon", '
              f'vertices = {concave!r}, element_size = 40.0 }}\n', contact=False)


def test_floe_field_power_law_sizes_without_overlap():
    """Sizes follow ``p(d) ~ d^-alpha`` on ``[a, b]``: the maximum-likelihood exponent of 20 000
    draws is within 3 standard errors (``(alpha - 1)/sqrt(n)`` for the untruncated law: 0.007);
    the placed floes do not overlap (no overlapping pair between floes), and the covered share
    reaches the target without passing it by more than the last floe placed."""
    f = FloeField({**{k: p.default for k, p in FloeField.params.items()},
                   "lon": [0.0, 0.1], "lat": [0.0, 0.1], "size_min": 100.0, "size_max": 5000.0,
                   "exponent": 2.5})
    d = f.sizes(np.random.default_rng(0), 20_000)
    assert d.min() >= 100.0 and d.max() <= 5000.0

    def nll(al):
        return -(np.log((al - 1) / (100.0 ** (1 - al) - 5000.0 ** (1 - al))) - al * np.log(d)).sum()

    from scipy.optimize import minimize_scalar

    fit = minimize_scalar(nll, bounds=(1.1, 4.0), method="bounded").x
    assert fit == pytest.approx(2.5, abs=3 * 1.5 / math.sqrt(len(d)))
    text = (BASE + '[[elements.source]]\nname = "floe_field"\nparams = { lon = [-170.02, '
            '-170.0], lat = [60.0, 60.01], size_min = 150.0, size_max = 600.0, '
            'concentration = 0.4, element_size = 60.0, seed = 4 }\n[contact]\nlaw = '
            '"bonded_particle"\n')
    sim = Simulation(scene_from_text(text), out=False, progress=False)
    st = sim.state
    nf = st.floe.max() + 1
    assert nf >= 3
    F = np.zeros((st.n, 2))
    sim.contacts.add(0.0, st.q, st.V, st.w, F, np.zeros(st.n), False)
    on = sim.contacts.pair_active == 1
    pairs = sim.contacts.pairs[on]
    assert not np.any(st.floe[pairs[:, 0]] != st.floe[pairs[:, 1]])
    # joints only inside floes
    assert np.all(st.floe[sim.contacts.ji] == st.floe[sim.contacts.jj])
    W = 6_371_000.0 * math.radians(0.02) * math.cos(math.radians(60.005))
    H = 6_371_000.0 * math.radians(0.01)
    cover = st.area.sum() / (W * H)
    biggest = max(np.bincount(st.floe, weights=st.area)) / (W * H)
    assert 0.4 - biggest <= cover <= 0.4 + biggest


# ---------------------------------------------------------------------------- the plugin kind


class Triangle(ElementSource):
    """Test source: one triangle near a given point."""

    name = "test_triangle"
    from siku_core.params import Param as _P

    params = {"lon": _P(0.0, "deg", "longitude"), "size": _P(0.01, "deg", "size", min=0)}

    def build(self, scene, seed, where):
        x, s = self.p["lon"], self.p["size"]
        return [ElementSpec(np.array([[x, 0.0], [x + s, 0.0], [x, s]]), flag="static",
                            label="the triangle")]


def _plugin():
    mod = types.ModuleType("siku_test_triangle")

    @hookimpl
    def siku_register_element_sources():
        return [Triangle]

    mod.siku_register_element_sources = siku_register_element_sources
    return mod


def test_third_party_source_by_name_with_table_defaults():
    mod = _plugin()
    register_module(mod)
    try:
        sim = build('[[elements.source]]\nname = "test_triangle"\nthickness = 2.5\n'
                    'params = { lon = 3.0 }\n[[elements.polygon]]\nvertices = [[0, 1], '
                    '[0.01, 1], [0, 1.01]]\n', contact=False)
        st = sim.state
        # order: polygon tables first, then [[elements.source]] tables
        assert st.n == 2 and st.thickness.tolist() == [1.0, 2.5]
        assert st.flags[1] == 1  # the source's own flag wins over the table default
        with pytest.raises(SceneError, match=r"source\[0\]\.params.*'size'"):
            build('[[elements.source]]\nname = "test_triangle"\nparams = { size = -1.0 }\n',
                  contact=False)
    finally:
        unregister_module(mod)


def test_unknown_source_lists_the_known_ones():
    with pytest.raises(Exception, match=r"elements.source\[0\].*unknown element source "
                                        r"'tile'.*floe.*mesh.*pack.*polygon"):
        build('[[elements.source]]\nname = "tile"\n', contact=False)


def test_builtin_sources_by_name_give_the_same_elements_as_their_tables():
    keys = ["lon = [0.0, 0.1]", "lat = [0.0, 0.05]", "nx = 4", "ny = 2", "jitter = 0.2"]
    pack = ", ".join(keys)
    a = build("[[elements.pack]]\n" + "\n".join(keys) + "\n", contact=False).state
    b = build(f'[[elements.source]]\nname = "pack"\nparams = {{ {pack} }}\n',
              contact=False).state
    assert np.array_equal(a.q, b.q) and np.array_equal(a.verts, b.verts)


def test_engine_does_not_import_io_to_build_elements():
    """No engine module imports ``siku_io`` (the mesh source reaches the engine through the
    plugin hooks); only the command line draws pictures after a run with it."""
    import ast
    from pathlib import Path

    import siku_core

    root = Path(siku_core.__file__).parent
    offenders = []
    for f in root.rglob("*.py"):
        if f.name == "cli.py":
            continue
        for node in ast.walk(ast.parse(f.read_text())):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            offenders += [f"{f.name}: {n}" for n in names if n.split(".")[0] == "siku_io"]
    assert not offenders


def test_the_compiled_builder_agrees_with_the_one_element_builder():
    """``siku_core.geometry.batch`` builds many elements in one compiled pass; against
    ``element_from_lonlat`` one at a time (squares of a pack, Voronoi cells of a floe) it gives
    the same elements to round-off: quaternions to 1e-15, vertices, areas and moments to 1e-11
    relative (the centre iteration may stop one round earlier or later when its step sits at
    the 1e-9 threshold; most elements come out bit for bit)."""
    from bench.scenes import scene
    from siku_core.run.elements import collect_specs
    from siku_core.geometry.batch import elements_from_lonlat
    from siku_core.geometry.polygon import element_from_lonlat

    for kind in ("bonded", "floe"):
        sc = scene(kind, 600)
        specs = collect_specs(sc)
        R = sc.cfg.planet.radius
        got = elements_from_lonlat([s.lonlat for s in specs], R, [s.label for s in specs])
        same = 0
        for s, (q, loc, a, j) in zip(specs, got):
            q0, loc0, a0, j0 = element_from_lonlat(s.lonlat, R, s.label)
            assert np.abs(q - q0).max() <= 1e-15
            assert np.abs(loc - loc0).max() <= 1e-11 * np.abs(loc0).max()
            assert a == pytest.approx(a0, rel=1e-11) and j == pytest.approx(j0, rel=1e-11)
            same += np.array_equal(loc, loc0) and np.array_equal(q, q0)
        assert same >= 0.9 * len(specs)


def test_the_compiled_builder_reports_a_faulty_polygon_like_the_one_element_builder():
    from siku_core.errors import GeometryError
    from siku_core.geometry.batch import elements_from_lonlat

    good = [[0, 0], [1, 0], [1, 1], [0, 1]]
    crossing = [[0, 0], [1, 1], [1, 0], [0, 1]]
    with pytest.raises(GeometryError, match=r"^element 1: cell B: polygon crosses itself"):
        elements_from_lonlat([good, crossing, good], 6.371e6, ["cell A", "cell B", "cell C"])
