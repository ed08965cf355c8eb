"""``--threads N``: every command that computes takes it, refuses a bad count as a usage
error naming the flag, records the threads beside the kernels, and the results do not
depend on it."""

import json
import os

import pytest

from blisk_cam.cli import main as cli
from blisk_cam.core import runtime
from blisk_cam.core.part.blisk import make_demo_blisk
from tests.support.mesh_files import write_binary_stl


@pytest.fixture(scope="module")
def blade(tmp_path_factory):
    d = make_demo_blisk(resolution=0.4)
    path = str(write_binary_stl(tmp_path_factory.mktemp("blade") / "blade.stl", d.blade_vertices,
                                d.blade_faces))
    return path, [str(x) for x in d.hub_cone.as_list()], [str(x) for x in d.tip_cone.as_list()]


@pytest.mark.parametrize("command", cli.THREADED_COMMANDS)
@pytest.mark.parametrize("bad", ["0", "-2", "two", "1.5"])
def test_a_bad_thread_count_is_a_usage_error_naming_the_flag(command, bad, capsys):
    rc = cli.main([command, "--threads", bad])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2
    assert len(err) == 1 and "--threads" in err[0] and err[0].startswith("blisk_cam: error:")


def test_an_inner_default_follows_the_callers_count():
    assert runtime.requested_workers() is None
    with runtime.parallel(1) as n:
        assert n == 1 and runtime.requested_workers() == 1
        with runtime.parallel(None) as inner:  # a library default inside the user's choice
            assert inner == 1 and runtime.workers() == 1
    with runtime.parallel(None) as n:
        assert n == runtime.default_workers()
    assert runtime.requested_workers() is None and runtime.workers() == 1


def _without_timings(data):
    st = data["stats"]
    for k in [k for k in st if k.startswith("seconds")] + ["threads"]:
        st.pop(k)
    return data


def test_paths_verify_gives_the_same_json_on_one_and_two_threads(blade, tmp_path, capsys):
    stl, cone1, cone2 = blade
    runs = {}
    for n in (1, 2):
        out = tmp_path / f"p{n}.json"
        rc = cli.main(["paths", "--mesh", stl, "--cone1", *cone1, "--cone2", *cone2,
                       "--tool-diameter", "12", "--cusp", "0.5", "--chord", "0.2", "--lead", "10",
                       "--verify", "--quiet", "--threads", str(n), "--out", str(out)])
        printed = capsys.readouterr().out
        assert rc == 0
        data = json.loads(out.read_text())
        assert data["stats"]["threads"] == n
        kernels = next(x for x in printed.splitlines() if "kernels:" in x)
        assert kernels.endswith(f"{n} thread" + ("s" if n > 1 else ""))
        runs[n] = _without_timings(data)
    assert runs[1] == runs[2]


def test_the_cli_leaves_a_users_arena_limit_alone(monkeypatch):
    from blisk_cam.cli import allocator

    monkeypatch.setenv("MALLOC_ARENA_MAX", "4")
    assert allocator.use_one_heap() is False  # the environment's choice stands


def test_the_cli_asks_for_one_blas_thread_before_numpy_loads():
    """``python -m blisk_cam`` sets OPENBLAS_NUM_THREADS=1 before numpy is imported (OpenBLAS
    reads it once, at load), unless the user's environment names a count."""
    import subprocess
    import sys

    probe = ("import os, runpy, sys\n"
             "sys.argv = ['blisk_cam', '--version']\n"
             "try:\n    runpy.run_module('blisk_cam', run_name='__main__')\n"
             "except SystemExit:\n    pass\n"
             "print(os.environ.get('OPENBLAS_NUM_THREADS'), 'numpy' in sys.modules)\n")
    for user, want in ((None, "1"), ("3", "3")):
        env = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
        if user is not None:
            env["OPENBLAS_NUM_THREADS"] = user
        out = subprocess.run([sys.executable, "-c", probe], env=env, capture_output=True,
                             text=True, check=True, timeout=120).stdout.split()
        assert out[-2:] == [want, "True"]
