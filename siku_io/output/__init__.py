"""Output files: the HDF5 and CF-NetCDF writers, their readers and restart, the catalogue of what
each dataset holds (layout), the xarray backend (xr) and ``siku export``."""
