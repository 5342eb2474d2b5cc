"""Voronoi meshes of sea ice on the sphere (docs/explanation/physics.md §6; report "Ice
Generation"): the region (:mod:`.region`), land and coastlines (:mod:`.land`, :mod:`.gshhg`,
landfast :mod:`.contours`), seeding (:mod:`.seeding`), Voronoi cells (:mod:`.voronoi`,
:mod:`.merge`), the build (:mod:`.build`; small cells relaxed by :mod:`.relax`), the mesh and
its file (:mod:`.mesh_file`), the cache (:mod:`.cache`), the initial ice cover
(:mod:`.icecover`) and the ``mesh`` element source (:mod:`.source`)."""
from siku_core.deprecation import moved_names

#: names the module ``siku_io.mesh`` held before it became this package (siku 0.2.0), by their
#: new module: deprecation aliases (:mod:`siku_core.deprecation`)
__getattr__ = moved_names(__name__, {
    "COAST": "siku_io.mesh.mesh_file", "ICE": "siku_io.mesh.mesh_file",
    "LANDFAST": "siku_io.mesh.mesh_file", "Mesh": "siku_io.mesh.mesh_file",
    "MeshParams": "siku_io.mesh.params", "Region": "siku_io.mesh.region",
    "build_mesh": "siku_io.mesh.build", "load_or_build": "siku_io.mesh.cache",
    "mesh_for_scene": "siku_io.mesh.cache",
})
