"""Input/output: HDF5 output and restart, meshes, coastlines, plots (imported lazily)."""
