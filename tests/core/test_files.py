"""core/files: every output is written atomically with the mode a plain ``open`` gives; a
failure (Ctrl-C included) leaves the old file as it was and no temporary file behind."""

from __future__ import annotations

import os

import pytest

from blisk_cam.core.errors import BliskCamError, PostError
from blisk_cam.core.files import atomic_output, umask, write_atomic
from blisk_cam.core.post.common import write_atomic as write_program


def test_text_and_bytes_land_whole_with_the_umask_mode(tmp_path):
    f = tmp_path / "out.txt"
    write_atomic(f, "a\nb ø\n")
    assert f.read_bytes() == "a\nb ø\n".encode()
    assert (os.stat(f).st_mode & 0o777) == 0o666 & ~umask()
    write_atomic(f, b"\x00\x01")
    assert f.read_bytes() == b"\x00\x01"
    assert os.listdir(tmp_path) == ["out.txt"]


def test_an_interrupted_write_keeps_the_old_file_and_leaves_nothing(tmp_path):
    f = tmp_path / "program.ngc"
    f.write_text("good")
    with pytest.raises(KeyboardInterrupt), atomic_output(f) as tmp:
        with open(tmp, "w") as fh:
            fh.write("half")
        raise KeyboardInterrupt
    assert f.read_text() == "good" and os.listdir(tmp_path) == ["program.ngc"]


def test_a_missing_directory_is_the_callers_error(tmp_path):
    with pytest.raises(BliskCamError, match="does not exist"):
        write_atomic(tmp_path / "no" / "x.json", "{}")
    with pytest.raises(PostError, match="does not exist"):
        write_program(tmp_path / "no" / "x.ngc", "G0")
