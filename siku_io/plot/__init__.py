"""Pictures: maps and animations of element outputs (element_maps) and of gridded files
(grid_maps), their decoration (mapdeco) and ``siku plot``."""
