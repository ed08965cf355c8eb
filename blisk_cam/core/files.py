"""Writing the user's files: atomically, with the mode a plain ``open`` gives.

Every output (paths JSON, NC and robot programs, simulation reports, meshes, stock states) is
written to a temporary file beside the target and renamed into place, so a failure or Ctrl-C
never leaves a half-written file where a good one was, and no temporary file is left behind.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import tempfile

from .errors import BliskCamError

__all__ = ["atomic_output", "umask", "write_atomic"]


def umask() -> int:
    """The process umask (read by setting it and putting it back)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_output(filename, *, suffix: str = ".tmp", error: type[BliskCamError] = BliskCamError):
    """Context manager yielding a temporary file name beside ``filename`` (ending in
    ``suffix``, for writers that insist on an extension): write it inside the block; on a clean
    exit it gets mode 0666 less the umask and replaces ``filename``; on any exception (Ctrl-C
    included) it is removed and ``filename`` is untouched. A missing directory → ``error``."""
    filename = os.fspath(filename)
    folder = os.path.dirname(os.path.abspath(filename))
    if not os.path.isdir(folder):
        raise error(f"cannot write {filename}: the directory {folder} does not exist")
    fd, tmp = tempfile.mkstemp(prefix=".blisk_", suffix=suffix, dir=folder)
    os.close(fd)
    try:
        yield tmp
        # mkstemp makes the file 0600; an output is the user's file like any other
        os.chmod(tmp, 0o666 & ~umask())
        os.replace(tmp, filename)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def file_sha256(filename) -> str:
    """SHA-256 (hex) of a file's bytes, read in 1 MiB chunks."""
    h = hashlib.sha256()
    with open(filename, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def write_atomic(filename, data: str | bytes, *,
                 error: type[BliskCamError] = BliskCamError) -> str:
    """Write ``data`` (text as UTF-8 with ``\\n`` line ends, or bytes) to ``filename``
    atomically (:func:`atomic_output`, flushed to disk before the rename). Returns the name."""
    filename = os.fspath(filename)
    with atomic_output(filename, error=error) as tmp:
        if isinstance(data, bytes):
            fh = open(tmp, "wb")  # noqa: SIM115 — closed below, after fsync
        else:
            fh = open(tmp, "w", encoding="utf-8", newline="\n")  # noqa: SIM115
        with fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
    return filename
