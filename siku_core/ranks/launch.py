"""``siku run --ranks N``: the command under ``mpiexec``, and a rank that dies told in one line.

The launcher (``mpiexec`` of the ``mpich`` wheel) ends every rank when one dies, and prints a
banner on its standard output naming the dead process's id. :func:`launch` runs it with each
rank noting its process id in a folder (:data:`PIDS`, :func:`note_pid`), passes every other
line through, and replaces the banner by one line naming the rank and the cause.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

#: the environment variable naming the folder where each rank notes its process id
PIDS = "SIKU_RANK_PIDS"
_BANNER = re.compile(r"^(=+|=   .*|YOUR APPLICATION TERMINATED.*|This typically refers.*|"
                     r"Please see the FAQ.*)$")
_PID = re.compile(r"PID (\d+) RUNNING")
_WHY = re.compile(r"EXIT STRING: (.*)$|EXIT CODE: (\d+)")


def note_pid(rank: int) -> None:
    """Note this process's id as rank ``rank`` where :func:`launch` looks (if it does)."""
    folder = os.environ.get(PIDS)
    if folder and Path(folder).is_dir():
        (Path(folder) / str(os.getpid())).write_text(str(rank), encoding="utf-8")


def note_abort() -> None:
    """Note that a rank ended the run itself, having said why (:func:`launch` adds nothing)."""
    folder = os.environ.get(PIDS)
    if folder and Path(folder).is_dir():
        (Path(folder) / "aborted").write_text("", encoding="utf-8")


def launch(cmd: list[str]) -> int:
    """Run ``cmd`` (an ``mpiexec`` command line); its exit status."""
    with tempfile.TemporaryDirectory(prefix="siku-ranks-") as own:
        folder = os.environ.get(PIDS) or own
        env = {**os.environ, PIDS: folder}
        p = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, text=True, bufsize=1)
        pid, why = None, None
        assert p.stdout is not None
        for line in p.stdout:
            text = line.rstrip("\n")
            if _BANNER.match(text):
                pid = pid or (_PID.search(text) and _PID.search(text).group(1))  # type: ignore
                m = _WHY.search(text)
                if m:
                    why = m.group(1) or why or f"exit code {m.group(2)}"
                continue
            sys.stdout.write(line)
        p.stdout.close()
        rc = p.wait()
        if pid is not None and not (Path(folder) / "aborted").exists():
            f = Path(folder) / pid
            who = f"rank {f.read_text(encoding='utf-8')}" if f.exists() else f"process {pid}"
            print(f"siku: error: {who} ended ({why or 'killed'}); the run stopped on every "
                  "rank", file=sys.stderr)
        return rc
