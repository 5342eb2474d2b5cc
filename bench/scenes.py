"""Benchmark scenes, written as the TOML a user would write (``siku_core.scene.scene_file``).

* ``bonded``: the Siku-like pack of the performance issue: ``nx × ny`` squares of 0.2° (about
  22 km) centred on the equator, 1 m thick, every shared edge jointed (``joints = "auto"``),
  the west column static, the east column steady at 3 m/s east, a uniform 10 m/s wind through
  ``air_drag``. Joint strengths are high enough that no joint breaks during a benchmark, so the
  joint count stays fixed (about two joints per element). Any law of ``LAW_PARAMS``.
* ``collision``: a broken pack for the ``collision`` law: the same grid, but every element is
  its own polygon, scaled up by 2 % about its centre and its corners jittered by up to 0.4 % of
  the cell, so that every candidate pair (edge and diagonal neighbours) overlaps and is clipped
  and evaluated every step. A short ``dt`` keeps the overlaps (and so the work) the same over a
  benchmark. It runs under the engine's default ``contact.touching`` (``"ignore"``): its
  overlaps are real, so either rule finds the same contacts.
* ``bonded`` and ``floe`` state ``contact.touching = "contact"`` (the rule of the Siku model,
  the engine's default until ``"ignore"`` became it), so that their numbers compare with the
  earlier tables of ``bench/RESULTS.md``;
* ``bonded_ignore``: the bonded pack with ``contact.touching = "ignore"`` (the engine's
  default): jointed neighbours
  whose overlap stays within the clip's tolerance exert no contact force and are settled by the
  separating-axis test instead of the clip (docs/explanation/contacts.md, "Touching").
* ``free_drift``: the bonded pack without a ``[contact]`` table: forcing and integrator only.
* ``floe``: one bonded floe (Orzech et al.) of about ``n`` Voronoi elements of mean size 5 km
  (element source ``floe``, a 2 : 1 rectangle on the equator), law ``bonded_particle`` with
  strengths that nothing reaches, a uniform 10 m/s wind; about three bonds per element (a
  Voronoi packing has six neighbours per cell) against the square pack's two. Any other joint
  law of ``LAW_PARAMS`` runs on the same elements and joints.
* ``floe_ignore``: the floe with ``contact.touching = "ignore"``.
* ``bonded_exclude``, ``floe_exclude``: the pack and the floe with ``contact.jointed =
  "exclude"``: a jointed pair is no collision candidate while its joint holds (the
  bonded-particle convention, as the LAMMPS runs of ``bench.peers``; contacts.md §3.1).

Sizes are given as element counts; :func:`grid` picks the columns and rows.
"""
from __future__ import annotations

import math

import numpy as np

from siku_core.scene.scene_file import Scene, scene_from_text
from siku_core.testing.scenes import toml_value

#: element side in degrees (the issue's "0.2° squares at the equator")
CELL_DEG = 0.2
#: time step of the bonded and free-drift scenes [s] (the 0.2° pack's critical step is ~6 s)
DT_BONDED = 2.0
#: time step of the collision scene [s]: overlaps of ~440 m change by < 1 m per 100 steps
DT_COLLISION = 0.05

#: joint parameters that keep every joint intact over a benchmark (3 m/s pull: strain < 1e-2)
LAW_PARAMS = {
    "collision": {},
    "distributed_spring": {"tensile_strain": 0.05},
    "mohr_coulomb": {"sigma_c": 1e12},
    "bonded_particle": {"sigma_crit": 1e12, "tau_crit": 1e12},
}
LAWS = tuple(LAW_PARAMS)
#: the benchmark scenes (:func:`text`)
KINDS = ("bonded", "bonded_ignore", "bonded_exclude", "collision", "free_drift", "floe",
         "floe_ignore", "floe_exclude")


def grid(n: int) -> tuple[int, int]:
    """Columns and rows of a pack of about ``n`` elements: square for squares, else the
    divisor pair nearest a square (3 000 -> 60 × 50)."""
    r = int(round(math.sqrt(n)))
    if r * r == n:
        return r, r
    best = None
    for ny in range(1, r + 1):
        if n % ny == 0:
            best = (n // ny, ny)
    if best is not None and best[0] <= 4 * best[1]:
        return best
    return r, max(1, round(n / r))


def _head(title: str, dt: float, steps: int) -> list[str]:
    return [
        f"title = {toml_value(title)}",
        f"[time]\nduration = {toml_value(dt * steps)}\ndt = {toml_value(dt)}",
        "[materials.ice]\nyoungs_modulus = 1.0e9\ndensity = 910.0\npoisson_ratio = 0.3",
        "[elements]\nthickness = 1.0",
    ]


#: largest extent of a pack [deg]: bigger packs get smaller cells (the 400 000 and 1 000 000
#: element runs), with the time step scaled alike (the critical step is proportional to the
#: cell size at a given E and h)
MAX_SPAN_DEG = 40.0


def cell_deg(nx: int, ny: int) -> float:
    """Cell side [deg] of an ``nx`` by ``ny`` pack: 0.2°, or less for packs wider than 40°."""
    return min(CELL_DEG, MAX_SPAN_DEG / max(nx, ny))


def _broad(nx: int, ny: int) -> str:
    """Packs of small cells (above 40 000 elements) use the cell grid: sweep-and-prune along
    one axis holds a whole column of a square pack in each sweep window (O(n^1.5): 38 s for the
    first candidate list of 1 000 000 elements, against a few with the grid; same pairs)."""
    return '\nbroad_phase = "cell_grid"' if cell_deg(nx, ny) < CELL_DEG else ""


def _scaled(dt: float, nx: int, ny: int) -> float:
    """A 0.2° pack's time step for the pack's cells (12 digits)."""
    return float(f"{dt * cell_deg(nx, ny) / CELL_DEG:.12g}")


def _pack_box(nx: int, ny: int) -> tuple[list[float], list[float]]:
    c = cell_deg(nx, ny)
    return [0.0, nx * c], [-0.5 * ny * c, 0.5 * ny * c]


WIND = ('[[forcing]]\nsource = "air_drag"\n'
        'field = { type = "uniform", params = { u = 10.0, v = 0.0 } }')


def bonded_text(n: int, law: str = "distributed_spring", steps: int = 100,
                contact: bool = True, wind: bool = True, touching: str = "contact",
                jointed: str = "collide") -> str:
    """The Siku-like bonded pack of about ``n`` elements (``contact=False``: free drift;
    ``touching``, ``jointed``: the ``contact`` options)."""
    nx, ny = grid(n)
    lon, lat = _pack_box(nx, ny)
    title = f"bench {'bonded ' + law if contact else 'free drift'} {nx}x{ny}"
    parts = _head(title, _scaled(DT_BONDED, nx, ny), steps)
    parts.append(
        "[[elements.pack]]\n"
        f"lon = {toml_value(lon)}\nlat = {toml_value(lat)}\nnx = {nx}\nny = {ny}\n"
        'left = "static"\nright = "steady"\nright_velocity = [3.0, 0.0]'
    )
    if contact:
        parts.append(
            f'[contact]\nlaw = {toml_value(law)}\njoints = "auto"\n'
            f"params = {toml_value(LAW_PARAMS[law])}" + _broad(nx, ny)
            + _options(touching, jointed)
        )
    if wind:
        parts.append(WIND)
    parts.append("[run]\nprogress = false")
    return "\n\n".join(parts) + "\n"


def collision_text(n: int, steps: int = 100, overlap: float = 0.02, jitter: float = 0.004,
                   seed: int = 1) -> str:
    """The collision-dominated broken pack of about ``n`` elements."""
    nx, ny = grid(n)
    lon, lat = _pack_box(nx, ny)
    rng = np.random.default_rng(seed)
    xs = np.linspace(lon[0], lon[1], nx + 1)
    ys = np.linspace(lat[0], lat[1], ny + 1)
    s = 1.0 + overlap
    parts = _head(f"bench collision {nx}x{ny}", _scaled(DT_COLLISION, nx, ny), steps)
    polys = []
    for i in range(nx):
        for j in range(ny):
            cx, cy = 0.5 * (xs[i] + xs[i + 1]), 0.5 * (ys[j] + ys[j + 1])
            v = np.array([[xs[i], ys[j]], [xs[i + 1], ys[j]], [xs[i + 1], ys[j + 1]],
                          [xs[i], ys[j + 1]]])
            v = np.array([cx, cy]) + s * (v - np.array([cx, cy]))
            v += rng.uniform(-jitter, jitter, v.shape) * cell_deg(nx, ny)
            polys.append("[[elements.polygon]]\nvertices = "
                         + toml_value([[round(a, 9), round(b, 9)] for a, b in v]))
    parts.append("\n\n".join(polys))
    parts.append('[contact]\nlaw = "collision"\njoints = "none"' + _broad(nx, ny))
    parts.append("[run]\nprogress = false")
    return "\n\n".join(parts) + "\n"


#: mean element size of the floe scene [m] and its time step [s] (critical step ~1.5 s)
FLOE_D = 5000.0
DT_FLOE = 0.5


def floe_text(n: int, steps: int = 100, touching: str = "contact",
              law: str = "bonded_particle", jointed: str = "collide") -> str:
    """One bonded floe of about ``n`` elements (``element_size`` 5 km, 2 : 1 rectangle;
    ``touching``, ``jointed``: the ``contact`` options; ``law``: its joints,
    ``bonded_particle`` as in Orzech et al., or another joint law on the same elements and
    joints)."""
    width = math.sqrt(n / 2.0) * FLOE_D
    params = dict(outline="rectangle", center=[10.0, 0.0], length=2 * width, width=width,
                  element_size=FLOE_D, seed=1)
    parts = _head(f"bench floe {n}", DT_FLOE, steps)
    parts.append(f'[[elements.source]]\nname = "floe"\nparams = {toml_value(params)}')
    parts.append(f'[contact]\nlaw = {toml_value(law)}\njoints = "auto"\n'
                 f"params = {toml_value(LAW_PARAMS[law])}" + _options(touching, jointed))
    parts.append(WIND)
    parts.append("[run]\nprogress = false")
    return "\n\n".join(parts) + "\n"


def _options(touching: str, jointed: str) -> str:
    """The ``[contact]`` lines of the options that differ from their defaults."""
    return (("" if touching == "ignore" else f"\ntouching = {toml_value(touching)}")
            + ("" if jointed == "collide" else f"\njointed = {toml_value(jointed)}"))


def scene(kind: str, n: int, law: str | None = None, steps: int = 100) -> Scene:
    """A validated benchmark scene: ``kind`` is one of :data:`KINDS`; ``law``: the contact
    law of a bonded pack or a floe (default: ``distributed_spring`` for a pack,
    ``bonded_particle`` for a floe)."""
    return scene_from_text(text(kind, n, law, steps), f"<bench {kind} {n}>")


def text(kind: str, n: int, law: str | None = None, steps: int = 100) -> str:
    """The TOML of a benchmark scene (as :func:`scene` builds it)."""
    touching = "ignore" if kind.endswith("_ignore") else "contact"
    jointed = "exclude" if kind.endswith("_exclude") else "collide"
    if kind in ("floe", "floe_ignore", "floe_exclude"):
        return floe_text(n, steps, touching=touching, law=law or "bonded_particle",
                         jointed=jointed)
    law = law or "distributed_spring"
    if kind in ("bonded", "bonded_ignore", "bonded_exclude"):
        return bonded_text(n, law, steps, touching=touching, jointed=jointed)
    if kind == "free_drift":
        return bonded_text(n, steps=steps, contact=False)
    if kind == "collision":
        return collision_text(n, steps)
    raise ValueError(f"unknown benchmark scene '{kind}'; known: {', '.join(KINDS)}")


if __name__ == "__main__":  # python -m bench.scenes bonded 10000 [law] [steps] > scene.toml
    import sys

    args = sys.argv[1:]
    if not 2 <= len(args) <= 4:
        sys.exit("usage: python -m bench.scenes KIND ELEMENTS [LAW] [STEPS] > scene.toml")
    sys.stdout.write(text(args[0], int(args[1]), *(args[2:3] or [None]),
                          *[int(a) for a in args[3:4]]))
