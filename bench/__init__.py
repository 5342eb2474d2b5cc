"""siku benchmarks (not tests, not installed): ``python -m bench`` or ``siku bench``.

See ``bench/README.md``; results in ``bench/RESULTS.md``.
"""
