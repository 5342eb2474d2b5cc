"""Built-in element sources: single polygons and rectangular packs.

``[[elements.polygon]]`` and ``[[elements.pack]]`` tables feed them (their keys are validated by
the scene loader: ``docs/reference/scene.md``); a scene may also name them in an
``[[elements.source]]`` table with the same keys in ``params``.
"""
from __future__ import annotations

import numpy as np

from siku_core import hookimpl
from siku_core.interfaces import ElementSource, ElementSpec
from siku_core.scene.packs import rect_pack
from siku_core.scene.scene_file import PackCfg, PolygonCfg


class PolygonSource(ElementSource):
    """One element from ``[lon, lat]`` vertices in degrees (``[[elements.polygon]]``)."""

    name = "polygon"
    table_model = PolygonCfg

    def build(self, scene, seed, where):
        p = self.p
        return [ElementSpec(np.array(p["vertices"], dtype=float), p["flag"], p["velocity"],
                            p["spin"], p["thickness"], p["material"])]


class PackSource(ElementSource):
    """An ``nx × ny`` pack of quadrilaterals over a lon/lat box (``[[elements.pack]]``)."""

    name = "pack"
    table_model = PackCfg

    def build(self, scene, seed, where):
        p = self.p
        out = []
        for cell in rect_pack(p["lon"], p["lat"], p["nx"], p["ny"], p["gap"], p["jitter"], seed):
            flag, vel = p["flag"], p["velocity"]
            if cell.i == 0 and p["left"] is not None:
                flag, vel = p["left"], p["left_velocity"]
            elif cell.i == p["nx"] - 1 and p["right"] is not None:
                flag, vel = p["right"], p["right_velocity"]
            out.append(ElementSpec(cell.lonlat, flag, vel, p["spin"], p["thickness"],
                                   p["material"], f"cell (i={cell.i}, j={cell.j})"))
        return out


@hookimpl
def siku_register_element_sources():
    return [PolygonSource, PackSource]
