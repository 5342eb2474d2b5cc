"""siku as users install it: one version everywhere, the package data declared, and (slow) the
wheel that ``python -m build`` makes, installed into a fresh virtual environment outside the
source tree, running a scene from its own data, listing its plugins and passing the example
plugin's tests."""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import tomllib
import zipfile
from fnmatch import fnmatch
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("siku_core", "siku_plugins", "siku_forcing", "siku_io")
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


def newest_release(changelog: str) -> tuple[str, str]:
    """The newest ``## [X.Y.Z] - DATE`` of a Keep-a-Changelog file (not ``[Unreleased]``)."""
    got = re.search(r"^## \[(\d+\.\d+\.\d+)\] - (\d{4}-\d{2}-\d{2})\s*$", changelog, re.M)
    assert got, "CHANGELOG.md has no dated release"
    return got.group(1), got.group(2)


def test_one_version_the_changelogs_newest_release():
    """pyproject's version (the one source: siku_core.__version__ reads it from the installed
    metadata) is the changelog's newest release, and the citation files say the same."""
    version, date = newest_release((ROOT / "CHANGELOG.md").read_text())
    assert PYPROJECT["project"]["version"] == version
    assert "version" not in PYPROJECT["project"].get("dynamic", [])
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert (cff["version"], str(cff["date-released"])) == (version, date)
    assert cff["cff-version"] == "1.2.0" and cff["authors"] and cff["title"]
    zen = json.loads((ROOT / ".zenodo.json").read_text())
    assert (zen["version"], zen["publication_date"]) == (version, date)
    assert zen["upload_type"] == "software" and zen["creators"]
    assert cff["license"] == zen["license"] == PYPROJECT["project"]["license"]["text"]


def test_newest_release_skips_unreleased():
    text = "## [Unreleased]\n\n## [1.4.2] - 2030-01-02\n\n## [1.4.1] - 2029-12-01\n"
    assert newest_release(text) == ("1.4.2", "2030-01-02")


def test_every_file_a_package_ships_is_declared_package_data():
    """A data file beside the modules (the default scene, its winds) that package-data does not
    name would be missing from the wheel; every package also carries py.typed (PEP 561)."""
    declared = PYPROJECT["tool"]["setuptools"]["package-data"]
    tracked = subprocess.run(["git", "ls-files", *PACKAGES], cwd=ROOT, capture_output=True,
                             text=True)
    if tracked.returncode != 0:  # pragma: no cover - an unpacked sdist: no git
        pytest.skip("not a git checkout")
    data = [p for p in tracked.stdout.split() if not p.endswith(".py")]
    assert "siku_core/data/default_scene.toml" in data
    for path in data:
        package, rel = path.split("/", 1)
        assert any(fnmatch(rel, pat) for pat in declared.get(package, [])), path
    for package in PACKAGES:
        assert (ROOT / package / "py.typed").exists() and "py.typed" in declared[package]


def test_build_is_in_the_dev_extra():
    assert any(re.match(r"build\b", d) for d in PYPROJECT["project"]["optional-dependencies"]
               ["dev"])


# ------------------------------------------------------------------------ the installed wheel
TINY_SCENE = """\
title = "a tiny pack in the default scene's winds, from the installed package data"
[time]
start = 2001-04-06T00:00:00Z
duration = 600.0
dt = 60.0
[elements]
thickness = 1.5
[[elements.pack]]
lon = [-152.0, -151.0]
lat = [72.0, 72.3]
nx = 2
ny = 2
gap = 0.3
[[forcing]]
source = "air_drag"
field = {{ type = "gridded", params = {{ u_file = "{u}", v_file = "{v}" }} }}
[[forcing]]
source = "water_drag"
[[forcing]]
source = "coriolis"
[output]
file = "tiny.h5"
every = 300.0
"""


def _copy_tree(dest: Path) -> Path:
    """The source tree without build products, so that building writes nothing into it."""
    shutil.copytree(ROOT, dest, ignore=shutil.ignore_patterns(
        ".git", ".venv", "build", "dist", "*.egg-info", "__pycache__", "_build", "*.h5",
        "*.partial", ".pytest_cache", "*.nbi", "*.nbc", "out"))
    return dest


@pytest.mark.slow
def test_the_wheel_installed_outside_the_tree_runs_lists_plugins_and_passes_plugin_tests(
        tmp_path):
    work = tmp_path / "work"
    work.mkdir()
    src, dist, venv = _copy_tree(tmp_path / "src"), tmp_path / "dist", tmp_path / "venv"
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "SIKU_SKIP_PLUGINS", "VIRTUAL_ENV")}

    def sh(*cmd, cwd=work, timeout=900):
        r = subprocess.run([str(c) for c in cmd], cwd=cwd, env=env, capture_output=True,
                           text=True, timeout=timeout)
        assert r.returncode == 0, f"{cmd}\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}"
        return r.stdout

    # an sdist and a wheel from the sdist, as `python -m build` makes them
    sh(sys.executable, "-m", "build", "--outdir", dist, src, cwd=src)
    version = PYPROJECT["project"]["version"]
    wheel = dist / f"siku-{version}-py3-none-any.whl"
    assert (dist / f"siku-{version}.tar.gz").exists() and wheel.exists()
    names = set(zipfile.ZipFile(wheel).namelist())
    for data in ("siku_core/data/default_scene.toml", "siku_core/data/uwnd.anticyclone.nc",
                 "siku_core/data/vwnd.anticyclone.nc", "siku_core/py.typed"):
        assert data in names, data
    entry_points = zipfile.ZipFile(wheel).read(
        f"siku-{version}.dist-info/entry_points.txt").decode()
    assert "siku = siku_core.run.cli:main" in entry_points and "[xarray.backends]" in entry_points

    # a fresh environment (numpy and the other dependencies from the system's site-packages);
    # siku itself only from the wheel
    sh(sys.executable, "-m", "venv", "--system-site-packages", venv)
    py, siku = venv / "bin" / "python", venv / "bin" / "siku"
    sh(py, "-m", "pip", "install", "-q", "--no-deps", "--ignore-installed", wheel)
    where = json.loads(sh(py, "-c", "import json, siku_core, siku_core.run.cli as c; print(json."
                                    "dumps([siku_core.__file__, siku_core.__version__, "
                                    "str(c.default_scene_path())]))"))
    installed = venv.resolve()
    for path in (where[0], where[2]):
        assert Path(path).resolve().is_relative_to(installed), path
        assert not Path(path).resolve().is_relative_to(ROOT), path
    assert where[1] == version and Path(where[2]).exists()
    assert sh(siku, "--version").split()[-1] == version

    # a scene driven by the default scene's winds, read from the installed package data
    data = Path(where[2]).parent
    scene = work / "tiny.toml"
    scene.write_text(TINY_SCENE.format(u=data / "uwnd.anticyclone.nc",
                                       v=data / "vwnd.anticyclone.nc"))
    sh(siku, "run", "--no-progress", scene)
    sh(siku, "info", work / "tiny.h5")
    check = ("import h5py, numpy as np; f = h5py.File('tiny.h5'); "
             "assert list(f['states/step']) == [0, 5, 10], list(f['states/step']); "
             "V = f['states/V'][-1]; assert np.isfinite(V).all() and np.abs(V).max() > 1e-3; "
             f"assert f.attrs['siku_version'] == '{version}', dict(f.attrs)")
    sh(py, "-c", check)
    listed = sh(siku, "plugins")
    for name in ("distributed_spring", "air_drag", "siku2", "hdf5"):
        assert name in listed, name

    # the example plugin installed beside it: listed, and its own tests pass
    example = shutil.copytree(src / "examples" / "siku_example_plugin", tmp_path / "example")
    sh(py, "-m", "pip", "install", "-q", "--no-deps", example)
    assert "sea_surface_tilt" in sh(siku, "plugins")
    out = sh(py, "-m", "pytest", "-q", "-p", "no:cacheprovider", example / "tests",
             cwd=example, timeout=1800)
    assert " passed" in out and " failed" not in out

    # a package generated by the installed `siku new-plugin` (its template is package data of
    # the wheel): installed, its components listed, and its own default tests pass
    sh(siku, "new-plugin", "siku-wheel-demo", "--dir", tmp_path)
    generated = tmp_path / "siku-wheel-demo"
    sh(py, "-m", "pip", "install", "-q", "--no-deps", generated)
    listed = sh(siku, "plugins")
    for short in ("spring", "push", "growth", "centres", "squares"):
        assert f"siku_wheel_demo_{short}" in listed, short
    out = sh(py, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-m", "not slow",
             cwd=generated, timeout=1800)
    assert " passed" in out and " failed" not in out
