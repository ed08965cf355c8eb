"""Issue 28 row 4: a typo in a machine TOML is an error naming the key and the nearest known
one, never a silently dropped limit."""

from __future__ import annotations

import pytest

from blisk_cam.cli.main import main as cli_main
from blisk_cam.core.errors import MachineError
from blisk_cam.core.machine.description import MACHINES_DIR, known_presets, load_machine

PRESET = (MACHINES_DIR / "ac-trunnion.toml").read_text()


@pytest.mark.parametrize("old, new, key, nearest", [
    ("limits = [-10.0, 110.0]", "limts = [-10.0, 110.0]", "limts", "limits"),
    ("[linear]", "[linar]", "linar", "linear"),
    ("[part]", "[prat]", "prat", "part"),
    ("origin = [0, 0, 0]", "orign = [0, 0, 0]", "orign", "origin"),
    ('kinematics = "table-table"', 'kinematics = "table-table"\npivot_lenght = 3',
     "pivot_lenght", "pivot_length"),
    ("X = [-400, 400]", "x = [-400, 400]", "x", "X"),
])
def test_unknown_key_names_it_and_the_nearest(tmp_path, old, new, key, nearest):
    assert old in PRESET
    f = tmp_path / "typo.toml"
    f.write_text(PRESET.replace(old, new, 1))
    with pytest.raises(MachineError) as err:
        load_machine(f)
    text = str(err.value)
    assert f"'{key}'" in text and f"'{nearest}'" in text


def test_presets_have_no_unknown_keys():
    for name in known_presets():
        load_machine(name)


def test_nc_refuses_the_typo_toml_before_writing(tmp_path, capsys):
    f = tmp_path / "typo.toml"
    f.write_text(PRESET.replace("limits =", "limts =", 1))
    out = tmp_path / "x.ngc"
    rc = cli_main(["nc", "--paths", str(tmp_path / "missing.json"), "--machine", str(f),
                   "--post", "linuxcnc", "--out", str(out)])
    err = capsys.readouterr().err
    # the machine is read first (cheap), before the paths file
    assert rc == 1 and not out.exists() and err.count("\n") == 1 and "'limts'" in err
