"""A built mesh (seeds, CSR polygons of lon/lat vertices, kinds of cell) and its ``.npz`` file."""
from __future__ import annotations

import json
import os
import uuid
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from siku_core.geometry.sphere import lonlat_to_xyz

from .sphere import DEFAULT_RADIUS, spherical_polygon_areas
from .voronoi import cell_pairs

MESH_VERSION = 1
FORMAT = "siku-mesh"
ICE, COAST, LANDFAST = 0, 1, 2
KIND_NAMES = ("ice", "coast", "landfast")


# ---------------------------------------------------------------------------- the mesh
@dataclass
class Mesh:
    """Cells of a mesh: CSR polygons of ``[lon, lat]`` (degrees, counter-clockwise), the global
    vertex id of each polygon vertex (shared by neighbours), seeds, kinds (``ICE``, ``COAST``,
    ``LANDFAST``), the parameters and their hash, and build statistics."""

    offsets: np.ndarray
    lonlat: np.ndarray
    vertex_id: np.ndarray
    seeds: np.ndarray
    kind: np.ndarray
    params: dict
    digest: str
    stats: dict = field(default_factory=dict)

    @property
    def n(self) -> int:
        return len(self.offsets) - 1

    def cell(self, i: int) -> np.ndarray:
        return self.lonlat[self.offsets[i]:self.offsets[i + 1]]

    def polygons(self) -> list[np.ndarray]:
        return [self.cell(i) for i in range(self.n)]

    @property
    def static(self) -> np.ndarray:
        return self.kind != ICE

    def counts(self) -> dict[str, int]:
        return {name: int(np.sum(self.kind == k)) for k, name in enumerate(KIND_NAMES)}

    def xyz(self) -> np.ndarray:
        return lonlat_to_xyz(self.lonlat[:, 0], self.lonlat[:, 1])

    def spherical_areas(self, R: float | None = None) -> np.ndarray:
        """Cell areas on the sphere [m²] (great-circle edges)."""
        R = float(self.params.get("radius", DEFAULT_RADIUS)) if R is None else R
        return spherical_polygon_areas(self.offsets, self.xyz(), R)

    def neighbours(self) -> np.ndarray:
        """Pairs ``(i, j)``, ``i < j``, of cells sharing an edge (both its vertices)."""
        return cell_pairs(self.offsets, self.vertex_id)

    # ------------------------------------------------------------------ file
    def save(self, path: str | Path) -> Path:
        """Write an ``.npz`` (atomically: a temporary file, then renamed)."""
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.{uuid.uuid4().hex}.tmp")
        try:
            with open(tmp, "wb") as f:
                np.savez_compressed(
                    f, format=np.array(FORMAT), version=np.array(MESH_VERSION),
                    digest=np.array(self.digest), params=np.array(json.dumps(self.params)),
                    stats=np.array(json.dumps(self.stats)), offsets=self.offsets,
                    lonlat=self.lonlat, vertex_id=self.vertex_id, seeds=self.seeds,
                    kind=self.kind,
                )
            os.replace(tmp, path)
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
        return path

    @classmethod
    def load(cls, path: str | Path) -> Mesh:
        with np.load(Path(path), allow_pickle=False) as z:
            if str(z["format"]) != FORMAT:
                raise ValueError(f"{path}: not a siku mesh file")
            if int(z["version"]) != MESH_VERSION:
                raise ValueError(f"{path}: mesh format version {int(z['version'])}, "
                                 f"this siku reads {MESH_VERSION}")
            return cls(
                offsets=z["offsets"], lonlat=z["lonlat"], vertex_id=z["vertex_id"],
                seeds=z["seeds"], kind=z["kind"], params=json.loads(str(z["params"])),
                digest=str(z["digest"]), stats=json.loads(str(z["stats"])),
            )
