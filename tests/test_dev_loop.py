"""The developer loop: CI runs exactly the README's test command, the long validation is left
out of it by the ``slow`` marker, and the README names the command that runs it."""
from __future__ import annotations

import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _readme_test_command() -> str:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    m = re.search(r"Install and run the tests:\s*```bash\n(.+?)\n```", text, re.S)
    assert m, "README.md: no test command after 'Install and run the tests:'"
    return m.group(1).strip()


def test_ci_runs_exactly_the_readme_s_test_command():
    lines = [ln.strip() for ln in (ROOT / ".ci" / "run").read_text().splitlines()
             if ln.strip() and not ln.lstrip().startswith(("#", "set ", "cd "))]
    assert lines == [_readme_test_command()]


def test_the_slow_validation_is_left_out_by_default_and_its_command_documented():
    opts = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["pytest"]["ini_options"]
    assert '-m "not slow"' in opts["addopts"]
    assert any(m.startswith("slow:") for m in opts["markers"])
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "python -m pytest -q -m slow" in readme
