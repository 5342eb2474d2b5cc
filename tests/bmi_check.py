"""Run the CSDMS ``bmi-tester`` suite (its own tests, unchanged) on
``siku_io.coupling.bmi:SikuBmi``.

``python tests/bmi_check.py SCENE.toml`` from the directory holding the scene; exit status 0 when
every stage passes. Each stage runs as ``bmi-test`` runs it (``bmi_tester.api.check_bmi``), with
``--confcutdir`` at the tester's package so that pytest 8 loads the tester's ``conftest.py``
(``bmi-test`` itself leaves pytest's default, the stage directory, and its fixtures are then not
found). ``--import-mode=importlib``: the tester's conftest is imported without putting its
site-packages first on ``sys.path``, where another installed copy of siku would then shadow the
one under test.
"""
from __future__ import annotations

import sys
from pathlib import Path

import bmi_tester
from bmi_tester.api import check_bmi


def main(scene: str) -> int:
    root = Path(bmi_tester.__file__).parent
    marker = Path(".ROOT_DIR")  # where the tester finds the scene; removed when done
    marker.write_text(str(Path.cwd()))
    try:
        return _stages(root, scene)
    finally:
        marker.unlink(missing_ok=True)


def _stages(root: Path, scene: str) -> int:
    stages = [root / "_bootstrap", *sorted((root / "_tests").glob("stage_*"))]
    status = 0
    for stage in stages:
        rc = check_bmi("siku_io.coupling.bmi:SikuBmi", tests_dir=str(stage), input_file=scene,
                       manifest=[scene], bmi_version="2.0",
                       extra_args=["--confcutdir", str(root), "--import-mode=importlib",
                                   "-p", "no:cacheprovider", "-q",
                                   "-rs", "-W", "ignore::DeprecationWarning"])
        print(f"bmi-tester {stage.name}: exit {int(rc)}", flush=True)
        status |= int(rc)
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
