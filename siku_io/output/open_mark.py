"""The open-for-write mark of an HDF5 output file: an HDF5 library marks a file it has open
for writing in its superblock (version 2/3), and a killed writer leaves the mark behind.
:func:`clear_open_mark` clears it in place (the superblock checksum, Bob Jenkins' lookup3,
recomputed); :class:`MarkedReader` reads a marked file through a view with the mark cleared,
never writing it. Both read only the file's first bytes before deciding, so neither needs the
rest of :mod:`siku_io.output`."""
from __future__ import annotations

import os
import struct
from pathlib import Path

from siku_core import DataError

_SIGNATURE = b"\x89HDF\r\n\x1a\n"


def lookup3(data: bytes) -> int:
    """Bob Jenkins' lookup3 ``hashlittle`` with initial value 0: the checksum of HDF5 metadata
    (HDF5 file format specification, "Checksum")."""
    m = 0xFFFFFFFF

    def rot(x: int, k: int) -> int:
        return ((x << k) | (x >> (32 - k))) & m

    n = len(data)
    a = b = c = (0xDEADBEEF + n) & m
    i = 0
    while n > 12:
        a = (a + int.from_bytes(data[i:i + 4], "little")) & m
        b = (b + int.from_bytes(data[i + 4:i + 8], "little")) & m
        c = (c + int.from_bytes(data[i + 8:i + 12], "little")) & m
        a = (a - c) & m
        a ^= rot(c, 4)
        c = (c + b) & m
        b = (b - a) & m
        b ^= rot(a, 6)
        a = (a + c) & m
        c = (c - b) & m
        c ^= rot(b, 8)
        b = (b + a) & m
        a = (a - c) & m
        a ^= rot(c, 16)
        c = (c + b) & m
        b = (b - a) & m
        b ^= rot(a, 19)
        a = (a + c) & m
        c = (c - b) & m
        c ^= rot(b, 4)
        b = (b + a) & m
        n -= 12
        i += 12
    if n == 0:
        return c
    tail = data[i:i + n] + bytes(12 - n)
    a = (a + int.from_bytes(tail[0:4], "little")) & m
    b = (b + int.from_bytes(tail[4:8], "little")) & m
    c = (c + int.from_bytes(tail[8:12], "little")) & m
    c ^= b
    c = (c - rot(b, 14)) & m
    a ^= c
    a = (a - rot(c, 11)) & m
    b ^= a
    b = (b - rot(a, 25)) & m
    c ^= b
    c = (c - rot(b, 16)) & m
    a ^= c
    a = (a - rot(c, 4)) & m
    b ^= a
    b = (b - rot(a, 14)) & m
    c ^= b
    c = (c - rot(b, 24)) & m
    return c


def clear_open_mark(path: str | Path) -> bool:
    """Clear the "open for writing" flags a killed writer leaves in the superblock of an HDF5
    file (format version 2 or 3 superblock at offset 0), as ``h5clear -s`` does; ``False`` if
    there was nothing to clear. Refused while another process holds the file."""
    import fcntl

    path = Path(path)
    fd = os.open(path, os.O_RDWR)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise DataError(f"{path}: is being written by another process") from None
        head = os.pread(fd, 48, 0)
        if len(head) < 48 or head[:8] != _SIGNATURE or head[8] not in (2, 3) or head[9] != 8:
            raise DataError(f"{path}: not an HDF5 file with a version 2/3 superblock")
        if struct.unpack("<I", head[44:48])[0] != lookup3(head[:44]):
            raise DataError(f"{path}: corrupt HDF5 superblock (checksum)")
        if head[11] == 0 and os.fstat(fd).st_size >= struct.unpack("<Q", head[28:36])[0]:
            return False
        eof = struct.unpack("<Q", head[28:36])[0]
        size = os.fstat(fd).st_size
        new = bytearray(head)
        if size < eof:  # a block HDF5 allotted but could not write (full disk): nothing
            new[28:36] = struct.pack("<Q", size)  # written refers to it, so end the file here
        new[11] = 0
        new[44:48] = struct.pack("<I", lookup3(bytes(new[:44])))
        os.pwrite(fd, bytes(new), 0)
        os.fsync(fd)
        return True
    finally:
        os.close(fd)


def _cleared(head: bytes, size: int) -> bytes | None:
    """The first 48 bytes of an HDF5 file (version 2/3 superblock) with the "open for writing"
    flags cleared and the end of the file fitted to ``size``, as :func:`clear_open_mark`
    writes them; ``None`` when ``head`` is no such superblock or its checksum is wrong."""
    if len(head) < 48 or head[:8] != _SIGNATURE or head[8] not in (2, 3) or head[9] != 8:
        return None
    if struct.unpack("<I", head[44:48])[0] != lookup3(head[:44]):
        return None
    new = bytearray(head[:48])
    if size < struct.unpack("<Q", head[28:36])[0]:
        new[28:36] = struct.pack("<Q", size)
    new[11] = 0
    new[44:48] = struct.pack("<I", lookup3(bytes(new[:44])))
    return bytes(new)


class MarkedReader:
    """A read-only file object over an HDF5 file a killed writer left marked "open for
    writing", showing its superblock with the mark cleared: h5py opens it (``driver="fileobj"``)
    without anything written to the file and without SWMR's retries (which wait minutes on a
    damaged file)."""

    def __init__(self, path: str | Path):
        self.fh = open(path, "rb")
        size = os.fstat(self.fh.fileno()).st_size
        self.head = _cleared(self.fh.read(48), size)
        if self.head is None:
            self.fh.close()
            raise OSError(f"{path}: not an HDF5 file with a version 2/3 superblock")
        self.fh.seek(0)

    def seek(self, offset: int, whence: int = 0) -> int:
        return self.fh.seek(offset, whence)

    def tell(self) -> int:
        return self.fh.tell()

    def read(self, n: int = -1) -> bytes:
        at = self.fh.tell()
        data = self.fh.read(n)
        if at < 48 and data:
            k = min(48 - at, len(data))
            data = self.head[at:at + k] + data[k:]
        return data

    def readinto(self, buf) -> int:
        data = self.read(len(buf))
        memoryview(buf)[:len(data)] = data
        return len(data)

    def close(self) -> None:
        self.fh.close()
