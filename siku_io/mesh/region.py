"""The region of a mesh: a lon/lat box, possibly across the antimeridian, or the whole sphere."""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from siku_core.geometry.sphere import lonlat_to_xyz, xyz_to_lonlat


# ---------------------------------------------------------------------------- region
@dataclass(frozen=True)
class Region:
    """A longitude–latitude box: ``lon0`` eastward over ``width`` degrees, ``lat0..lat1``.

    ``width >= 360`` is the full circle of longitude (a cap, a band or the whole sphere).
    """

    lon0: float
    width: float
    lat0: float
    lat1: float

    @classmethod
    def box(cls, lon: Sequence[float], lat: Sequence[float]) -> Region:
        """From ``[west, east]`` and ``[south, north]`` (degrees); east <= west wraps eastward
        across the antimeridian, ``[-180, 180]`` is the full circle. A box wider than the full
        circle (``east - west > 360``, a typing slip such as ``[-1500, -149.5]``) is refused:
        it would silently become the full circle."""
        w, e = float(lon[0]), float(lon[1])
        s, n = float(lat[0]), float(lat[1])
        if not (-90.0 <= s < n <= 90.0):
            raise ValueError(f"lat = [{s:g}, {n:g}]: need -90 <= south < north <= 90")
        if not (math.isfinite(w) and math.isfinite(e)) or e - w > 360.0:
            raise ValueError(f"lon = [{w:g}, {e:g}]: need east - west <= 360 (the full circle "
                             "is [-180, 180]; east < west wraps across the antimeridian)")
        width = e - w
        if width <= 0:
            width += 360.0
        if width >= 360.0 - 1e-9:
            width = 360.0
        lon0 = (w + 180.0) % 360.0 - 180.0
        return cls(lon0, width, s, n)

    @property
    def full_lon(self) -> bool:
        return self.width >= 360.0

    def contains(self, lon, lat) -> np.ndarray:
        lon = np.asarray(lon, dtype=float)
        lat = np.asarray(lat, dtype=float)
        ok = (lat >= self.lat0) & (lat <= self.lat1)
        if self.full_lon:
            return ok
        return ok & (((lon - self.lon0) % 360.0) <= self.width)

    def contains_xyz(self, p) -> np.ndarray:
        return self.contains(*xyz_to_lonlat(p))

    def area(self, R: float) -> float:
        """Area on the sphere of radius ``R`` [m²]."""
        return R * R * math.radians(self.width) * (
            math.sin(math.radians(self.lat1)) - math.sin(math.radians(self.lat0)))

    def expanded(self, margin_m: float, R: float) -> Region:
        """A box holding every point within ``margin_m`` of this one."""
        d = math.degrees(margin_m / R)
        s, n = max(-90.0, self.lat0 - d), min(90.0, self.lat1 + d)
        if self.full_lon or n >= 90.0 or s <= -90.0:
            return Region(-180.0, 360.0, s, n)
        c = math.cos(math.radians(max(abs(s), abs(n))))
        x = math.sin(margin_m / R) / c
        if x >= 1.0:
            return Region(-180.0, 360.0, s, n)
        dl = math.degrees(math.asin(x))
        if self.width + 2 * dl >= 360.0:
            return Region(-180.0, 360.0, s, n)
        return Region((self.lon0 - dl + 180.0) % 360.0 - 180.0, self.width + 2 * dl, s, n)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` points uniform by area in the box, as unit vectors."""
        lon = self.lon0 + rng.random(n) * self.width
        s0, s1 = math.sin(math.radians(self.lat0)), math.sin(math.radians(self.lat1))
        lat = np.degrees(np.arcsin(np.clip(s0 + rng.random(n) * (s1 - s0), -1.0, 1.0)))
        return lonlat_to_xyz(lon, lat)

    def as_params(self) -> dict:
        return {"lon0": self.lon0, "width": self.width, "lat0": self.lat0, "lat1": self.lat1}
