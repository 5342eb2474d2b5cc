"""Writing on a read-only file system: ``siku export``, ``siku grid`` (through
``write_whole``) and ``SceneBuilder.save`` (through ``write_text_file``) refuse in one line;
removing the partial file that could not be made is no second error."""
from __future__ import annotations

import errno
from pathlib import Path

import pytest

from siku_core.errors import DataError


def read_only(monkeypatch):
    """Every write and every removal fails as on a read-only file system (EROFS)."""
    def refuse(self, *a, **kw):
        raise OSError(errno.EROFS, "Read-only file system", str(self))

    monkeypatch.setattr(Path, "unlink", refuse)
    monkeypatch.setattr(Path, "write_text", refuse)


def test_write_whole_on_a_read_only_file_system_is_one_data_error(tmp_path, monkeypatch):
    from siku_io.output.marks import write_whole

    read_only(monkeypatch)

    def write(part: Path):
        raise OSError(errno.EROFS, "Read-only file system", str(part))

    with pytest.raises(DataError, match=r"run\.nc: cannot write: .*Read-only file system.* "
                                        "while writing the export file; nothing written"):
        write_whole(tmp_path / "run.nc", write, "export file")


def test_write_text_file_on_a_read_only_file_system_is_one_data_error(tmp_path, monkeypatch):
    from siku_core.run.outputs import write_text_file

    read_only(monkeypatch)
    with pytest.raises(DataError, match=r"scene\.toml: cannot be written \(Read-only file "
                                        r"system\); nothing written"):
        write_text_file(tmp_path / "scene.toml", "[time]\n", replace=False)
