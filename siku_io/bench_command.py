"""siku's developer commands: ``siku bench``, the benchmark runner of a source checkout (no
subpackage's concern: it runs the repository's ``bench/``), and ``siku new-plugin``, a plugin
package to grow from (``siku_io.new_plugin``)."""
from __future__ import annotations

from siku_core import hookimpl


def _cmd_bench(argv: list[str]) -> int:
    """``siku bench ...``: ``python -m bench ...`` of the repository's ``bench/`` (benchmarks are
    not installed, so this needs a source checkout: an editable install), in its own process."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    from siku_core.errors import SikuError

    root = Path(__file__).resolve().parents[1]
    if not (root / "bench" / "__main__.py").is_file():
        raise SikuError(f"siku bench needs a source checkout: {root / 'bench'} not found (siku "
                        "is not installed from a clone); clone the repository and run "
                        "'python -m bench' there")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(root), env.get("PYTHONPATH")) if p)
    return subprocess.call([sys.executable, "-m", "bench", *argv], env=env)


@hookimpl
def siku_register_commands(subparsers):
    b = subparsers.add_parser("bench", help="benchmark tables (source checkout; 'siku bench "
                              "--help')", add_help=False)
    b.set_defaults(func=_cmd_bench, raw_args=True)
    from siku_io.new_plugin import add_parser

    add_parser(subparsers)


