"""Every siku name the docs and the examples have ever told authors to import.

Reads every revision of the pages under ``docs`` (the how-to guides among them) and of the files
under ``examples`` (the example plugin among them) in the git history and collects the
``from siku_... import name`` and ``import siku_...`` statements they contain (in code blocks,
in prose between backticks, across parenthesised continuation lines). Prints one line per
import, sorted::

    siku_core.contacts J_AX
    siku_core -

(``-``: the statement imports the module itself). The list is what the deprecation aliases must
keep importable; tests/test_public_api.py holds its output (``HISTORY``) and checks that the list
there still covers the history. Run from the repository root::

    python tools/import_history.py
"""
from __future__ import annotations

import re
import subprocess
import sys

#: where authors are told what to import: the guides and the example plugin, and the pages
#: and example scripts around them
SCOPE = ("docs", "examples")
#: siku's own top-level packages
TOPS = ("siku_core", "siku_plugins", "siku_forcing", "siku_io")

_FROM = re.compile(r"from\s+((?:%s)(?:\.\w+)*)\s+import\s+(\([^)]*\)|[^\n`]*)" % "|".join(TOPS))
_IMPORT = re.compile(r"(?:^|[\s`;])import\s+((?:%s)(?:\.\w+)*)" % "|".join(TOPS), re.M)


def _git(*args: str) -> str:
    return subprocess.run(("git",) + args, check=True, capture_output=True,
                          text=True).stdout


def imports_in(text: str) -> set[tuple[str, str]]:
    """``(module, name)`` of every siku import statement in ``text`` (``name`` ``-`` for an
    import of the module itself)."""
    found = set()
    for mod, names in _FROM.findall(text):
        names = names.strip().strip("()")
        for part in names.replace("\\\n", " ").split(","):
            part = part.split("#")[0].strip()
            name = part.split(" as ")[0].strip()
            if re.fullmatch(r"[A-Za-z_]\w*", name):
                found.add((mod, name))
    for mod in _IMPORT.findall(text):
        found.add((mod, "-"))
    return found


def history(scope: tuple[str, ...] = SCOPE) -> set[tuple[str, str]]:
    """The imports of every file under ``scope`` at every revision that changed it."""
    found = set()
    for commit in _git("log", "--format=%H", "--", *scope).split():
        for path in _git("show", "--format=", "--name-only", commit, "--", *scope).split("\n"):
            if not path.endswith((".md", ".py")):
                continue
            try:
                text = _git("show", f"{commit}:{path}")
            except subprocess.CalledProcessError:  # deleted in this revision
                continue
            found |= imports_in(text)
    return found


def main() -> int:
    for mod, name in sorted(history()):
        print(mod, name)
    return 0


if __name__ == "__main__":
    sys.exit(main())
