"""``siku info`` reads what the other readers read: the output of a run killed with ``kill -9``
(HDF5's "open for writing" mark left set), counting its complete snapshots only; and it
identifies a file in a child process with a time limit, so a damaged output is refused in one
line, never a traceback or a hang."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import pytest

from siku_core.testing import scene_text

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_NUM_THREADS": "1"}


def siku(*args, cwd):
    return subprocess.run([sys.executable, "-m", "siku_core.run.cli", *map(str, args)],
                          capture_output=True, text=True, cwd=cwd, env=ENV, timeout=120)


@pytest.fixture(scope="module")
def killed(tmp_path_factory):
    """A one-element run of 10⁵ steps writing every step, killed with SIGKILL a second after
    its file appears."""
    d = tmp_path_factory.mktemp("killed")
    (d / "s.toml").write_text(scene_text([(0.0, 80.0)], dt=60.0, duration=6e6,
                                         output={"file": "k.h5", "every": 60.0}))
    p = subprocess.Popen([sys.executable, "-m", "siku_core.run.cli", "run", "s.toml",
                          "--no-progress"], cwd=d, env=ENV, stderr=subprocess.DEVNULL)
    t0 = time.monotonic()
    while not (d / "k.h5").exists() and time.monotonic() - t0 < 300:
        assert p.poll() is None
        time.sleep(0.01)
    time.sleep(1.0)
    p.send_signal(signal.SIGKILL)
    p.wait()
    with pytest.raises(OSError, match="already open for write"):
        h5py.File(d / "k.h5", "r")  # the mark a kill leaves
    return d


def test_info_reads_a_killed_runs_output_counting_complete_snapshots(killed):
    with h5py.File(killed / "k.h5", "r", swmr=True) as f:
        n = f["states/step"].shape[0]
        last = int(f["states/step"][n - 1])
    assert n > 1
    r = siku("info", "k.h5", cwd=killed)
    assert r.returncode == 0, r.stderr
    assert f"(stopped at step {last} of 100000)" in r.stdout


def test_info_refuses_a_damaged_output_in_one_line_without_hanging(killed, tmp_path):
    good = killed / "k.h5"
    bad = tmp_path / "bad.h5"
    data = bytearray(good.read_bytes())
    for k in range(1024, min(len(data), 1 << 16), 7):  # HDF5's internal records, past the
        data[k] ^= 0x5A                                # superblock's signature
    bad.write_bytes(bytes(data))
    t0 = time.monotonic()
    r = siku("info", bad, cwd=tmp_path)
    lines = [ln for ln in r.stderr.strip().splitlines() if ln]
    assert r.returncode == 2 and len(lines) == 1 and "bad.h5" in lines[0], r.stderr
    assert "Traceback" not in r.stderr and time.monotonic() - t0 < 100


def test_info_gives_up_a_file_whose_data_hang_the_hdf5_library(killed, tmp_path):
    """A file whose marks read well but whose data the HDF5 library never finishes reading
    (a damaged B-tree or heap inside it: here a read of ``/geometry/flags`` made to hang): the
    summary is read in a child process with a time limit (set to 3 s here), so ``siku info``
    ends with one line naming the file. On a summary read in the command's own process it hung
    for ever (the subprocess's limit of 120 s ended it)."""
    code = ("import sys, time\nimport h5py\nfrom siku_io.output import info\n"
            "info.TIMEOUT = 3.0\nreal = h5py.Dataset.__getitem__\n"
            "def hang(self, key):\n"
            "    if self.name == '/geometry/flags':\n        time.sleep(3600)\n"
            "    return real(self, key)\n"
            "h5py.Dataset.__getitem__ = hang\n"
            "from siku_core.run.cli import main\nsys.exit(main(sys.argv[1:]))\n")
    r = subprocess.run([sys.executable, "-c", code, "info", str(killed / "k.h5")],
                       capture_output=True, text=True, cwd=tmp_path, env=ENV, timeout=120)
    lines = [ln for ln in r.stderr.strip().splitlines() if ln]
    assert r.returncode == 2 and len(lines) == 1, r.stderr
    assert "k.h5" in lines[0] and "did not end within 3 s" in lines[0], lines[0]
