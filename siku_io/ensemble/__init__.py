"""Ensembles: sweep files (sweep, sweep_cfg), their members run on Dask (runs), the summary
dataset (summary) and ``siku ensemble``."""
