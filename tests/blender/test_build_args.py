"""Issue 14, item 5: ``make package`` builds one zip per platform by default (the all-platform
zip with six scipy wheels was 210 MB); ``--one-zip`` keeps the all-in-one. Argument handling
only (no download): the real builds are in test_extension.py."""

import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "scripts" / "build_extension.py"


@pytest.fixture(scope="module")
def be():
    spec = importlib.util.spec_from_file_location("build_extension_under_test", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _parse(be, argv, monkeypatch):
    """Run main() up to the split decision and stop (no download, no build): records what
    ``resolve_split`` decided; ``find_blender_ext``, the next step, is made to fail."""
    seen = {}
    orig = be.resolve_split

    def record(args, platforms):
        seen.update(args=args, platforms=platforms, split=orig(args, platforms))
        return seen["split"]

    def stop(explicit):
        raise be.BuildError("stopped by the test")

    monkeypatch.setattr(be, "resolve_split", record)
    monkeypatch.setattr(be, "find_blender_ext", stop)
    return be.main(argv), seen


@pytest.mark.parametrize(
    "argv, split",
    [
        ([], True),  # make package: every platform, one zip each
        (["--one-zip"], False),  # make package-all
        (["--split-platforms"], True),
        (["--platform", "linux-x64"], False),  # one platform: one zip
        (["--platform", "linux-x64", "--platform", "windows-x64"], True),
        (["--no-wheels"], False),  # nothing platform-specific to split
        (["--no-wheels", "--one-zip"], False),
    ],
)
def test_split_is_the_default_with_several_platforms(be, monkeypatch, argv, split):
    code, seen = _parse(be, argv, monkeypatch)
    assert code == 1  # stopped on purpose right after the resolution
    assert seen["split"] is split


def test_expected_zip_names(be, tmp_path, monkeypatch):
    _, seen = _parse(be, ["--output-dir", str(tmp_path)], monkeypatch)
    names = [p.name for p in be.expected_outputs(seen["args"], seen["platforms"])]
    version = be.tomllib.loads((ROOT / "blisk_cam" / "blender_manifest.toml").read_text())[
        "version"]
    assert names == [f"blisk_cam-{version}-{p}.zip" for p in ("linux_x64", "macos_arm64",
                                                               "windows_x64")]
    _, seen = _parse(be, ["--output-dir", str(tmp_path), "--one-zip"], monkeypatch)
    assert [p.name for p in be.expected_outputs(seen["args"], seen["platforms"])] == [
        f"blisk_cam-{version}.zip"]


def test_bad_combinations_are_refused_with_one_line():
    for argv, msg in (
        (["--no-wheels", "--split-platforms"], "--split-platforms needs the wheels"),
        (["--one-zip", "--split-platforms"], "not allowed with argument"),
    ):
        proc = subprocess.run([sys.executable, str(SCRIPT), *argv], cwd=ROOT,
                              capture_output=True, text=True, timeout=120,
                              stdin=subprocess.DEVNULL)
        assert proc.returncode != 0 and msg in proc.stderr, proc.stderr
        assert "Traceback" not in proc.stderr


def _fake_wheel(path, member, data):
    import zipfile

    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr(member, data)
    return path


def _elf(machine):
    head = bytearray(64)
    head[:5] = b"\x7fELF\x02"
    head[18:20] = machine.to_bytes(2, "little")
    return bytes(head)


def _macho(cputype):
    return b"\xcf\xfa\xed\xfe" + cputype.to_bytes(4, "little") + bytes(56)


def _pe(machine, imports=b"python3.dll"):
    head = bytearray(0x100)
    head[:2] = b"MZ"
    head[0x3C:0x40] = (0x80).to_bytes(4, "little")
    head[0x80:0x84] = b"PE\0\0"
    head[0x84:0x86] = machine.to_bytes(2, "little")
    return bytes(head) + imports


SYMBOL = b"PyInit_blisk_cam_kernels"


@pytest.mark.parametrize("platform, member, data, ok", [
    ("linux-x64", "blisk_cam_kernels/blisk_cam_kernels.abi3.so", _elf(0x3E) + SYMBOL, True),
    ("linux-x64", "blisk_cam_kernels/blisk_cam_kernels.abi3.so", _elf(0xB7) + SYMBOL, False),
    ("linux-x64", "blisk_cam_kernels/blisk_cam_kernels.abi3.so", _elf(0x3E), False),
    ("macos-arm64", "blisk_cam_kernels/blisk_cam_kernels.abi3.so", _macho(0x0100000C) + SYMBOL,
     True),
    ("macos-arm64", "blisk_cam_kernels/blisk_cam_kernels.abi3.so", _macho(0x01000007) + SYMBOL,
     False),
    ("windows-x64", "blisk_cam_kernels/blisk_cam_kernels.pyd", _pe(0x8664) + SYMBOL, True),
    ("windows-x64", "blisk_cam_kernels/blisk_cam_kernels.pyd", _pe(0x8664, b"python311.dll")
     + SYMBOL, False),
    ("windows-x64", "blisk_cam_kernels/blisk_cam_kernels.pyd", _pe(0xAA64) + SYMBOL, False),
    ("windows-x64", "blisk_cam_kernels/blisk_cam_kernels.so", _pe(0x8664) + SYMBOL, False),
])
def test_kernel_wheel_binary_is_checked(be, tmp_path, platform, member, data, ok):
    """A cross-built kernels wheel is bundled only if its extension is a module for the zip's
    platform: x86-64 ELF, arm64 Mach-O, x86-64 DLL on the stable ABI (python3.dll, not a
    version's DLL); anything else is refused with a line naming the wheel and the platform."""
    wheel = _fake_wheel(tmp_path / "k.whl", member, data)
    if ok:
        be.check_kernel_binary(wheel, platform)
    else:
        with pytest.raises(be.BuildError, match=f"k.whl.*{platform}|k.whl: expected one"):
            be.check_kernel_binary(wheel, platform)
