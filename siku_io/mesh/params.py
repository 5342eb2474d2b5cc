"""The parameters of a mesh: all that it is built from, and their hash."""
from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .land import GLM, LAND_SOURCES, glm_version
from .mesh_file import FORMAT, MESH_VERSION
from .region import Region
from .relax import MAX_SHARE
from .sphere import DEFAULT_RADIUS


# ---------------------------------------------------------------------------- parameters
@dataclass
class MeshParams:
    """Everything a mesh depends on; their hash names a cached mesh."""

    lon: Sequence[float]
    lat: Sequence[float]
    spacing: float
    coast_spacing: float | None = None
    coast_distance: float = 100_000.0
    seed: int = 0
    radius: float = DEFAULT_RADIUS
    land: str = GLM  # "global-land-mask", "gshhg" or "none"
    land_removal: str = "covered"  # or "seed"
    landfast: list | None = None  # list of polygons, each a list of [lon, lat]
    min_area_share: float = 0.0  # [1] free cells kept above this share of the median area


    def canonical(self) -> dict:
        lf = None
        if self.landfast:
            lf = [[[float(a), float(b)] for a, b in np.asarray(poly, dtype=float)]
                  for poly in self.landfast]
        out = {
            "lon": [float(self.lon[0]), float(self.lon[1])],
            "lat": [float(self.lat[0]), float(self.lat[1])],
            "spacing": float(self.spacing),
            "coast_spacing": None if self.coast_spacing is None else float(self.coast_spacing),
            "coast_distance": float(self.coast_distance),
            "seed": int(self.seed),
            "radius": float(self.radius),
            "land": str(self.land),
            "land_removal": str(self.land_removal),
            "landfast": lf,
        }
        if self.min_area_share:  # in the hash only when asked for: meshes built without it
            out["min_area_share"] = float(self.min_area_share)  # keep their hash and cache
        return out

    def identity(self) -> dict:
        return {"format": FORMAT, "version": MESH_VERSION, "params": self.canonical(),
                "land_data": self.land_data()}

    def land_data(self) -> str:
        """The land data set and its version (part of the hash: new data, or a new rule for
        what of it is land, rebuilds)."""
        if self.land == GLM:
            return f"{GLM} {glm_version()}"
        if self.land == "gshhg":
            from . import gshhg

            return (f"GSHHG {gshhg.choose_resolution(self.r_min)} ({gshhg.PACKAGE} "
                    f"{gshhg.version()}), level 1 whole")
        return self.land

    @property
    def r_min(self) -> float:
        """The smallest seed spacing [m]."""
        fine = self.coast_spacing
        return float(min(self.spacing, fine) if fine is not None else self.spacing)

    def digest(self) -> str:
        text = json.dumps(self.identity(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()

    def check(self) -> None:
        import math

        r = Region.box(self.lon, self.lat)
        if not self.spacing > 0:
            raise ValueError("spacing must be > 0")
        area = self.radius ** 2 * math.radians(r.width) * abs(
            math.sin(math.radians(r.lat1)) - math.sin(math.radians(r.lat0)))
        if not self.spacing < math.sqrt(area) / 2:
            raise ValueError(f"spacing = {self.spacing:g} m: the region is only about "
                             f"{math.sqrt(area):.3g} m across; choose a spacing below "
                             f"{math.sqrt(area) / 2:.3g} m (a mesh needs several cells)")
        if self.coast_spacing is not None and not self.coast_spacing > 0:
            raise ValueError("coast_spacing must be > 0")
        if not self.coast_distance >= 0:
            raise ValueError("coast_distance must be >= 0")
        if self.land not in LAND_SOURCES:
            raise ValueError(f"land = {self.land!r}: one of "
                             + ", ".join(f"'{x}'" for x in LAND_SOURCES))
        if not 0.0 <= self.min_area_share <= MAX_SHARE:
            raise ValueError(f"min_area_share = {self.min_area_share:g}: between 0 (off) and "
                             f"{MAX_SHARE:g}")
        if self.land_removal not in ("covered", "seed"):
            raise ValueError(f"land_removal = {self.land_removal!r}: one of 'covered', 'seed'")
