"""House style that can be checked: ``ruff`` clean at the project's line length.

Where code lives is decided by the structural rules of tests/test_structure.py (no import circle
inside a package, no other module's private names), not by a line count."""
from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_ruff_is_clean():
    """``ruff check .`` with the rules and line length of ``pyproject.toml``."""
    if shutil.which("ruff") is None:
        pytest.skip("ruff is not installed (it comes with the dev extra)")
    done = subprocess.run(["ruff", "check", "--no-cache", "."], cwd=ROOT, capture_output=True,
                          text=True)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-1000:]
