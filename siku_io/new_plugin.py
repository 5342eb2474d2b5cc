"""``siku new-plugin NAME [--dir D]``: a plugin package to grow from, one component of every
pluggable kind (contact law, forcing source, process, writer, element source, command), each a
small working example, with tests that run siku's conformance suites on them and pass as
generated.

The files are the templates of ``siku_io/new_plugin_template`` (``*.tmpl``, Python format
with the words ``{module}``, ``{dist}``, ``{command}`` and ``{siku_version}`` replaced).
"""
from __future__ import annotations

import re
from pathlib import Path

from siku_core.errors import DataError

TEMPLATES = Path(__file__).resolve().parent / "new_plugin_template"

#: template -> where it goes in the package (``{module}``: the import name)
TEMPLATE_FILES = {
    "pyproject.toml.tmpl": "pyproject.toml",
    "README.md.tmpl": "README.md",
    "__init__.py.tmpl": "{module}/__init__.py",
    "plugin.py.tmpl": "{module}/plugin.py",
    "law.py.tmpl": "{module}/law.py",
    "forcing.py.tmpl": "{module}/forcing.py",
    "process.py.tmpl": "{module}/process.py",
    "writer.py.tmpl": "{module}/writer.py",
    "source.py.tmpl": "{module}/source.py",
    "command.py.tmpl": "{module}/command.py",
    "conftest.py.tmpl": "tests/conftest.py",
    "test_plugin.py.tmpl": "tests/test_plugin.py",
}

NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_-]*[A-Za-z0-9]$|^[A-Za-z]$")


def names(name: str) -> dict[str, str]:
    """The distribution name, import name and command of plugin ``name`` (letters, digits,
    ``-`` and ``_``, starting with a letter); refused in one line otherwise."""
    if not NAME.match(name):
        raise DataError(f"{name!r}: a plugin name is letters, digits, '-' and '_', starting with "
                        "a letter and ending with a letter or digit (e.g. siku-ridges)")
    dist = name.lower().replace("_", "-")
    module = dist.replace("-", "_")
    return {"dist": dist, "module": module, "command": f"{dist}-count"}


def _fill(text: str, subs: dict[str, str]) -> str:
    for key, value in subs.items():
        text = text.replace("{" + key + "}", value)
    return text


def new_plugin(name: str, folder: str | Path = ".") -> Path:
    """Write the package of plugin ``name`` into ``folder/NAME`` (which must not exist) and
    return its path."""
    from siku_core import __version__

    subs = {**names(name), "siku_version": ".".join(__version__.split(".")[:2])}
    root = Path(folder) / name
    if root.exists() or root.is_symlink():
        raise DataError(f"{root}: exists; siku new-plugin writes a new folder only: choose "
                        "another NAME or --dir")
    files = {_fill(dest, subs): _fill((TEMPLATES / src).read_text(encoding="utf-8"), subs)
             for src, dest in TEMPLATE_FILES.items()}
    try:
        root.mkdir(parents=True)
    except OSError as exc:
        raise DataError(f"{root}: cannot create it ({exc.strerror})") from None
    for rel, text in files.items():
        path = root / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "x", encoding="utf-8") as f:
            f.write(text)
    return root


def _cmd_new_plugin(args) -> int:
    root = new_plugin(args.name, args.dir)
    n = names(args.name)
    print(f"{root}: a siku plugin package ({n['module']}); next: cd {root} && pip install -e . "
          "&& python -m pytest")
    return 0


def add_parser(subparsers) -> None:
    """The ``new-plugin`` subcommand (registered with siku's developer commands)."""
    p = subparsers.add_parser("new-plugin", help="generate a plugin package with one component "
                              "of every kind and its tests")
    p.add_argument("name", help="package name, e.g. siku-ridges (its import name: siku_ridges)")
    p.add_argument("--dir", default=".", help="folder to create NAME in (default: here)")
    p.set_defaults(func=_cmd_new_plugin)
