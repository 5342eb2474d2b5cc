"""Voronoi meshes of sea ice on the sphere (docs/explanation/physics.md §6; report "Ice
Generation"): the region (:mod:`.region`), land and coastlines (:mod:`.land`, :mod:`.gshhg`,
landfast :mod:`.contours`), seeding (:mod:`.seeding`), Voronoi cells (:mod:`.voronoi`,
:mod:`.merge`), the build (:mod:`.build`; small cells relaxed by :mod:`.relax`), the mesh and
its file (:mod:`.mesh_file`), the cache (:mod:`.cache`), the initial ice cover
(:mod:`.icecover`) and the ``mesh`` element source (:mod:`.source`)."""
