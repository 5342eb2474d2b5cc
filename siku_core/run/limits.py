"""Sane bounds checked before a run does any work: steps, elements, mesh rasters, memory.

A scene past a bound is refused with one line naming the key and the bound, instead of running
for days, filling the memory or building a mesh forever. The bounds are far above what a
2-core laptop or a large node runs (a million elements, a year in one-second steps).
"""
from __future__ import annotations

import math
import os
from typing import Callable

from ..errors import SceneError

#: most time steps one run may take (a year of 1 s steps is 3.2e7)
MAX_STEPS = 10**9
#: most ice elements one scene may build
MAX_ELEMENTS = 10**8
#: memory one element needs in a run with contacts [bytes]: state, geometry, contact candidate
#: lists and joints. Peak resident memory of bonded ``distributed_spring`` packs over the
#: interpreter with the engine imported: 3.4 kB per element at 40 000 elements, 2.3 kB at
#: 90 000 (a collision pack: 2.8 kB at 40 000); rounded up
BYTES_PER_ELEMENT = 4096
#: memory of one joint slot a process reserves [bytes]: the per-joint arrays
#: (``siku_core.contact.contact_joints``: indices, ends, rest state, history), rounded up
BYTES_PER_JOINT = 512
#: most pixels of the land raster a mesh builds (an eighth of the finest spacing per pixel)
MAX_LAND_PIXELS = 4 * 10**8


def physical_memory() -> int:
    """Memory of this machine [bytes] (``0`` when the system does not say)."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return 0


def most_count(unit_bytes: float, units: float = 1.0) -> str:
    """The largest count :func:`check_count` takes on this machine, for advice in messages:
    ``" (at most N on this machine)"``, or ``""`` when the system does not say its memory."""
    ram = physical_memory()
    return (f" (at most {math.floor(ram / 2.0 / (unit_bytes * max(units, 1.0))):.4g} on this "
            "machine)" if ram else "")


def check_count(where: str, key: str, value: float, unit_bytes: float, units: float = 1.0,
                what: str = "") -> None:
    """Refuse a count a user gives whose memory, ``value * units * unit_bytes`` [bytes], is
    more than half this machine's (:class:`SceneError` naming the key and the most allowed;
    ``what``: what one unit of the count holds, for the message). The other half is the run's
    elements, contacts and the interpreter."""
    ram = physical_memory()
    if not ram or not math.isfinite(value):
        return
    most = ram / 2.0 / (unit_bytes * max(units, 1.0))
    if value > most:
        raise SceneError(
            f"{where}: {key} = {value:g} needs {value * units * unit_bytes / 2**30:.3g} GiB"
            f"{what}, more than half of this machine's {ram / 2**30:.3g} GiB; allowed: "
            f"{key} at most {math.floor(most):.4g}")


def check_work(where: str, key: str, value: float, per_step: Callable[[float], float],
               steps: int, least: float = 1.0, dt: float | None = None) -> None:
    """Refuse a count that makes a run take more than :data:`MAX_STEPS` steps of its own
    (sub-steps: ``per_step(value)`` of them in each of the run's ``steps``), naming the key.

    The advice is one the scene can follow: the largest whole ``key`` whose sub-steps fit
    (found on ``per_step`` itself, so its rounding counts) when it is at least the key's own
    ``least`` allowed value; otherwise no value of ``key`` fits and the run must be shorter
    (at most so many steps; a duration with ``dt`` [s]). Sub-steps per step grow with the step,
    so a larger step is no remedy and is never advised."""
    total = per_step(value) * steps
    if total <= MAX_STEPS:
        return
    head = (f"{where}: {key} = {value:g} makes {per_step(value):.3g} sub-steps in each of the "
            f"run's {steps} steps, {total:.3g} in all, above the limit of {MAX_STEPS:.0e}")
    fits = per_step(least) * steps <= MAX_STEPS
    if not fits:
        steps_most = math.floor(MAX_STEPS / per_step(least))
        span = f" ([time] duration at most {math.floor(steps_most * dt)} s)" if dt else ""
        raise SceneError(f"{head}; even the least {key}, {least:g}, makes too many: shorten "
                         f"the run to at most {steps_most} steps{span}")
    lo, hi = math.ceil(least), math.floor(value)  # lo fits, hi does not
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if per_step(mid) * steps <= MAX_STEPS else (lo, mid)
    raise SceneError(f"{head}; allowed: {key} at most {lo} for this scene (or a shorter "
                     "[time] duration)")


def _box_area(lon: list[float], lat: list[float], R: float) -> float:
    """Area of a lon/lat box on a sphere of radius ``R`` [m²]."""
    dlon = math.radians((lon[1] - lon[0]) % 360.0 or 360.0)
    return R * R * dlon * abs(math.sin(math.radians(lat[1])) - math.sin(math.radians(lat[0])))


def estimate_elements(scene) -> float:
    """A lower estimate of the number of elements the scene's built-in tables make (sources
    named in ``[[elements.source]]`` check their own ``max_elements``)."""
    cfg = scene.cfg
    el = cfg.elements
    n = float(len(el.polygon)) + sum(float(p.nx) * float(p.ny) for p in el.pack)
    mc = el.mesh
    if mc is not None:
        R = cfg.planet.radius
        area = _box_area(mc.lon, mc.lat, R)
        n += area / mc.spacing / mc.spacing  # (never spacing², which a tiny spacing makes 0)
        if mc.coast_spacing is not None and mc.coast_spacing < mc.spacing:
            # a graded band of width coast_distance along about one box side of coast
            side = math.sqrt(area)
            n += side * mc.coast_distance / mc.coast_spacing / mc.spacing
    return n


def check_limits(scene, n_steps: int | None = None) -> None:
    """Refuse a scene past a bound (:class:`SceneError` naming the key and the bound)."""
    cfg = scene.cfg
    t = cfg.time
    for key, v in (("dt", t.dt), ("duration", t.total)):
        if not math.isfinite(v):
            raise SceneError(f"{scene.where('time')}: {key} = {v!r} s: give a finite duration")
    if n_steps is None and t.total < t.dt * (1.0 - 1e-9):
        raise SceneError(f"{scene.where('time')}: duration {t.total:g} s is shorter than one "
                         f"step (dt = {t.dt:g} s); give a duration of at least dt, or a "
                         "smaller dt")
    steps = n_steps if n_steps is not None else t.total / t.dt
    if steps > MAX_STEPS:
        raise SceneError(
            f"{scene.where('time')}: {t.total:.4g} s in steps of dt = {t.dt:g} s is {steps:.3g} "
            f"steps, above the limit of {MAX_STEPS:.0e} steps; shorten duration or raise dt")
    mc = cfg.elements.mesh
    if mc is not None and mc.land != "none":
        fine = min(mc.spacing, mc.coast_spacing or mc.spacing)
        R = cfg.planet.radius
        extra = 6.0 * max(mc.spacing, mc.coast_spacing or 0.0) + mc.coast_distance
        lon_w = math.radians(mc.lon[1] - mc.lon[0]) * R * math.cos(
            math.radians(min(80.0, max(abs(mc.lat[0]), abs(mc.lat[1]))))) + 2 * extra
        lat_w = math.radians(mc.lat[1] - mc.lat[0]) * R + 2 * extra
        pixel = fine / 8.0  # (never pixel², which a tiny spacing makes 0)
        pixels = (lon_w / pixel) * (lat_w / pixel)
        if pixels > MAX_LAND_PIXELS:
            raise SceneError(
                f"{scene.where('elements.mesh')}: spacing {fine:g} m over this box needs a land "
                f"raster of {pixels:.3g} pixels (an eighth of the finest spacing each), above "
                f"the limit of {MAX_LAND_PIXELS:.0e}; raise coast_spacing/spacing or shrink "
                "the box")
    n = estimate_elements(scene)
    if n > MAX_ELEMENTS:
        raise SceneError(f"{scene.where('elements')}: the scene would build about {n:.3g} "
                         f"elements, above the limit of {MAX_ELEMENTS:.0e}")
    ram = physical_memory()
    each = BYTES_PER_ELEMENT * max(1.0, math.sqrt(pack_aspect(scene)) / 2.0)
    need = n * each
    if ram and need > ram:
        raise SceneError(
            f"{scene.where('elements')}: about {n:.3g} elements need about "
            f"{need / 2**30:.3g} GiB ({each:.0f} bytes each), more than this machine's "
            f"{ram / 2**30:.3g} GiB of memory")


def pack_aspect(scene) -> float:
    """The largest length-to-width ratio of the cells of the scene's ``[[elements.pack]]``
    tables (``1``: none). Long thin elements have many contact candidates each: the memory an
    element needs grows about as the square root of this ratio (measured: 160 000 cells of
    1000:1 took about 60 kB each, 16 times a square cell's)."""
    worst = 1.0
    for p in scene.cfg.elements.pack:
        try:
            lat0, lat1 = float(p.lat[0]), float(p.lat[1])
            dx = abs(float(p.lon[1]) - float(p.lon[0])) * math.cos(
                math.radians(min(89.9, max(abs(lat0), abs(lat1))))) / max(int(p.nx), 1)
            dy = abs(lat1 - lat0) / max(int(p.ny), 1)
        except (TypeError, ValueError, AttributeError, IndexError):
            continue
        if dx > 0 and dy > 0 and math.isfinite(dx / dy):
            worst = max(worst, dx / dy, dy / dx)
    return worst


def check_components(scene, registry=None) -> None:
    """Check what a scene names without building it: every component's name (integrator,
    forcing sources and their fields, contact law and broad phase, writer, element sources) is
    registered and its parameters are valid; raises :class:`SceneError` naming the table, as
    building the :class:`Simulation` would. Cheap: no element, mesh or file is made."""
    from .elements import scene_sources
    from ..params import validate_params
    from ..plugins import get_registry

    reg = registry or get_registry()
    cfg = scene.cfg

    def one(kind: str, name: str, params: dict, table: str) -> None:
        where = scene.where(table)
        cls = reg.get(kind, name, where=f"{where}: ")
        validate_params(name, cls.params, params, where)

    one("integrator", cfg.integrator.name, cfg.integrator.params, "integrator")
    for k, f in enumerate(cfg.forcing):
        one("forcing", f.source, f.params, f"forcing[{k}]")
        if f.field is not None:
            one("field", f.field.type, f.field.params, f"forcing[{k}].field")
    if cfg.contact is not None:
        one("contact_law", cfg.contact.law, cfg.contact.params, "contact")
        one("broad_phase", cfg.contact.broad_phase, {}, "contact")
    one("writer", cfg.output.writer, cfg.output.params, "output")
    scene_sources(scene, reg)
