"""Analysis of results: regular grids, element fields gridded onto them (concentration, velocity,
deformation, stress), leads, and ``siku grid``."""
