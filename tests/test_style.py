"""House style that can be checked: ``ruff`` clean at the project's line length, and no module of
the four packages over 500 lines without the reason stated at its top."""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("siku_core", "siku_plugins", "siku_forcing", "siku_io")
#: what a long module's docstring says, in its first lines, to explain its length
REASON = "over 500 lines"


def test_ruff_is_clean():
    """``ruff check .`` with the rules and line length of ``pyproject.toml``."""
    if shutil.which("ruff") is None:
        pytest.skip("ruff is not installed (it comes with the dev extra)")
    done = subprocess.run(["ruff", "check", "--no-cache", "."], cwd=ROOT, capture_output=True,
                          text=True)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-1000:]


def unexplained_long_modules(paths) -> list[str]:
    """The modules among ``paths`` over 500 lines whose first 30 lines do not say why."""
    out = []
    for path in paths:
        lines = Path(path).read_text(encoding="utf-8").splitlines()
        if len(lines) > 500 and REASON not in " ".join(lines[:30]).lower():
            out.append(f"{path} ({len(lines)} lines)")
    return out


def test_long_modules_say_why():
    """A module over 500 lines states why in the first 30 lines of its docstring."""
    paths = [p for pkg in PACKAGES for p in (ROOT / pkg).rglob("*.py")]
    assert len(paths) > 50
    bad = unexplained_long_modules(paths)
    assert not bad, "modules over 500 lines without a reason at the top: " + ", ".join(bad)


def test_the_length_rule_flags_a_long_module_without_a_reason(tmp_path):
    """The rule is not vacuous: a long module is flagged without the sentence, not with it."""
    bare = tmp_path / "bare.py"
    bare.write_text('"""A module."""\n' + "x = 1\n" * 600)
    said = tmp_path / "said.py"
    said.write_text('"""A module.\n\nOver 500 lines for a reason: one table."""\n'
                    + "x = 1\n" * 600)
    assert unexplained_long_modules([bare, said]) == [f"{bare} (601 lines)"]
