#!/usr/bin/env python3
"""Build the Blisk CAM extension zip (``make package``).

Steps:

1. Download the scipy wheels Blender needs into ``blisk_cam/wheels/`` (git-ignored) with
   ``pip download --only-binary=:all: --no-deps --platform … --python-version …``: one per
   platform (linux-x64, macos-arm64, windows-x64) and Blender Python ABI (cp311 for Blender
   4.2–5.0, cp313 for 5.1 and later). numpy is never bundled: Blender ships it, and a second
   numpy breaks Blender and other add-ons.
2. Copy the package into a staging directory (``build/extension/blisk_cam``) and write the
   ``wheels = [...]`` (and ``platforms``) list into that copy of ``blender_manifest.toml``;
   the committed manifest is never edited.
3. Build with the extension CLI that ships in the bpy wheel
   (``bpy/<ver>/scripts/addons_core/bl_pkg/cli/blender_ext.py build``), then ``validate`` the
   zip.

By default every platform gets its own zip (``blisk_cam-<version>-linux_x64.zip``, ...): the
scipy wheels of all platforms together weigh ~200 MB, and a user needs one platform's.
``--one-zip`` builds the single all-platform zip instead. A build for one platform (or
without wheels) is one zip either way.

The compiled kernels (``kernels/``, Rust): with the wheels, one abi3 wheel per platform
(Python 3.11 and 3.13 alike) is built with maturin (``--zig`` when zig or ``ziglang`` is
installed: Linux as manylinux_2_28; without it the Linux wheel has this machine's glibc tag)
and bundled beside scipy. macOS arm64 and Windows x64 are cross-built with zig, which
``make package`` installs (``requirements/package.txt``) along with their Rust targets. Windows
is built for ``x86_64-pc-windows-gnu``: zig links it against the Universal CRT and
``python3.dll`` (the runtime Blender's own Python uses), while the ``-msvc`` target would need
Microsoft's SDK, which cannot be fetched from a package registry. Every built wheel's binary is
checked (machine type and, on Windows, that it imports ``python3.dll`` — the stable ABI)
before it is bundled. A platform whose Rust target is not installed (``rustup target add
…``), or a machine without cargo or maturin, gets none: that zip runs the numpy kernels (the
same paths, slower), and the script says so. ``--no-kernels`` skips them.

``--no-wheels`` skips step 1 (a small zip for tests: the test environment provides scipy).
Runs with any Python ≥ 3.11 that has the bpy wheel installed (or pass ``--blender-ext``).
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import re
import shutil
import struct
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE_DIR = ROOT / "blisk_cam"
MANIFEST = "blender_manifest.toml"

# Blender platform → pip --platform tags (in order of preference).
PLATFORMS = {
    "linux-x64": ["manylinux_2_17_x86_64", "manylinux2014_x86_64", "manylinux_2_28_x86_64"],
    "macos-arm64": ["macosx_12_0_arm64", "macosx_11_0_arm64"],
    "windows-x64": ["win_amd64"],
}

# Blender Python version → scipy release bundled for it.
#   3.11: Blender 4.2–5.0. Blender 4.2 ships numpy 1.24.3; scipy 1.15 is the last release that
#         accepts it (numpy >= 1.23.5) and still has cp311 wheels for every platform.
#   3.13: Blender 5.1+. numpy 2.x; scipy 1.18 (numpy >= 2.0, < 2.8).
SCIPY_FOR_PYTHON = {"3.11": "1.15.3", "3.13": "1.18.1"}

# Blender platform → Rust target of the compiled kernels' wheel.
KERNEL_TARGETS = {
    "linux-x64": "x86_64-unknown-linux-gnu",
    "macos-arm64": "aarch64-apple-darwin",
    "windows-x64": "x86_64-pc-windows-gnu",  # zig-linked, UCRT (module docstring)
}
KERNELS_DIR = ROOT / "kernels"

# Never bundled, whatever pip pulls in: numpy (Blender ships it); Dask (the batch runs,
# blisk_cam/batch, are a command-line extra: pip install blisk-cam[batch]).
FORBIDDEN_WHEELS = {"numpy": "Blender ships numpy",
                    "dask": "Dask is the command line's optional extra (blisk-cam[batch])",
                    "distributed": "Dask is the command line's optional extra (blisk-cam[batch])"}

# Copied into the staging directory: everything else of the package is left out here (the
# manifest's [build] paths_exclude_pattern filters again when Blender builds the zip).
STAGING_IGNORE = shutil.ignore_patterns(
    "__pycache__", "*.pyc", ".pytest_cache", ".hypothesis", ".ruff_cache", "wheels", "*.zip"
)


class BuildError(Exception):
    """A build step failed; the message says which and why."""


def find_blender_ext(explicit: str | None) -> Path:
    """Locate ``blender_ext.py`` in the installed bpy wheel (without importing bpy)."""
    if explicit:
        path = Path(explicit)
        if not path.is_file():
            raise BuildError(f"--blender-ext {path}: no such file")
        return path
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        raise BuildError(
            f"the bpy wheel is not installed for {sys.executable}; run this with "
            ".venv/bpy45/bin/python (make package) or pass --blender-ext PATH"
        )
    candidates = []
    for location in spec.submodule_search_locations:
        base = Path(location)
        for pattern in (
            "*/scripts/addons_core/bl_pkg/cli/blender_ext.py",
            "*/scripts/modules/**/bl_pkg/cli/blender_ext.py",
            "*/scripts/**/blender_ext.py",
        ):
            candidates.extend(sorted(base.glob(pattern)))
        if candidates:
            return candidates[0]
    raise BuildError(f"blender_ext.py not found under {list(spec.submodule_search_locations)}")


def run(cmd: list[str], what: str) -> None:
    print("+", " ".join(str(c) for c in cmd), flush=True)
    result = subprocess.run(cmd, stdin=subprocess.DEVNULL)
    if result.returncode != 0:
        raise BuildError(f"{what} failed (exit status {result.returncode})")


def _platform_ok(file_platforms: list[str], platform: str) -> bool:
    """A wheel's platform tags fit the Blender platform (and Blender's minimum OS)."""
    for tag in file_platforms:
        if platform == "linux-x64":
            # Blender 4.2+ needs glibc 2.28 itself, so any manylinux up to 2.28 runs.
            if tag in ("manylinux1_x86_64", "manylinux2010_x86_64", "manylinux2014_x86_64"):
                return True
            m = re.fullmatch(r"manylinux_2_(\d+)_x86_64", tag)
            if m and int(m.group(1)) <= 28:
                return True
        elif platform == "macos-arm64":
            # Blender runs on macOS 11.2+: no wheels that need a newer macOS than 12.
            m = re.fullmatch(r"macosx_(\d+)_\d+_arm64", tag)
            if m and int(m.group(1)) <= 12:
                return True
        elif platform == "windows-x64" and tag == "win_amd64":
            return True
    return False


def wheel_name_matches(name: str, version: str, pyver: str, platform: str) -> bool:
    """``scipy-<version>-cpXY-cpXY-<platform tags>.whl`` usable on ``platform``."""
    if not name.endswith(".whl"):
        return False
    parts = name[: -len(".whl")].split("-")
    if len(parts) not in (5, 6) or parts[0].lower() != "scipy" or parts[1] != version:
        return False
    tag = "cp" + pyver.replace(".", "")
    if parts[-3] != tag or parts[-2] != tag:
        return False
    return _platform_ok(parts[-1].split("."), platform)


def download_wheels(wheels_dir: Path, platforms: list[str], pythons: list[str]) -> list[Path]:
    """Download (or reuse) one scipy wheel per platform and Python version."""
    wheels_dir.mkdir(parents=True, exist_ok=True)
    chosen = []
    for platform in platforms:
        pip_platforms = PLATFORMS[platform]
        for pyver in pythons:
            version = SCIPY_FOR_PYTHON[pyver]
            existing = [
                p
                for p in sorted(wheels_dir.glob("scipy-*.whl"))
                if wheel_name_matches(p.name, version, pyver, platform)
            ]
            if not existing:
                cmd = [
                    sys.executable,
                    "-m",
                    "pip",
                    "download",
                    "--disable-pip-version-check",
                    "--no-input",
                    "--only-binary=:all:",
                    "--no-deps",
                    "--implementation",
                    "cp",
                    "--python-version",
                    pyver,
                    "--abi",
                    "cp" + pyver.replace(".", ""),
                    "--dest",
                    str(wheels_dir),
                ]
                for tag in pip_platforms:
                    cmd += ["--platform", tag]
                cmd.append(f"scipy=={version}")
                run(cmd, f"downloading scipy {version} for {platform}, Python {pyver}")
                existing = [
                    p
                    for p in sorted(wheels_dir.glob("scipy-*.whl"))
                    if wheel_name_matches(p.name, version, pyver, platform)
                ]
            if not existing:
                raise BuildError(
                    f"pip did not produce a scipy {version} wheel for {platform}, "
                    f"Python {pyver} in {wheels_dir}"
                )
            chosen.append(existing[0])
    for wheel in chosen:
        why = FORBIDDEN_WHEELS.get(wheel.name.split("-")[0].lower())
        if why:
            raise BuildError(f"refusing to bundle {wheel.name}: {why}")
    return chosen


def _cargo() -> str | None:
    found = shutil.which("cargo")
    home = Path.home() / ".cargo" / "bin" / "cargo"
    return found or (str(home) if home.is_file() else None)


def _rust_targets(cargo: str) -> set[str]:
    """The Rust targets installed here (rustup's list, or the host's alone)."""
    rustup = shutil.which("rustup") or str(Path(cargo).with_name("rustup"))
    try:
        out = subprocess.run([rustup, "target", "list", "--installed"], capture_output=True,
                             text=True, timeout=60, check=True).stdout
        return set(out.split())
    except (OSError, subprocess.SubprocessError):
        return {_host_target(cargo)}


def _host_target(cargo: str) -> str:
    out = subprocess.run([str(Path(cargo).with_name("rustc")), "-vV"], capture_output=True,
                         text=True, timeout=60).stdout
    return next((ln.split()[1] for ln in out.splitlines() if ln.startswith("host:")), "")


def _zig_available() -> bool:
    """zig for maturin's cross-linking: on PATH, or ziglang for this Python or python3."""
    if shutil.which("zig") or importlib.util.find_spec("ziglang") is not None:
        return True
    try:
        return subprocess.run([shutil.which("python3") or "python3", "-m", "ziglang", "version"],
                              capture_output=True, timeout=60).returncode == 0
    except (OSError, subprocess.SubprocessError):
        return False


def build_kernel_wheels(out_dir: Path, platforms: list[str]) -> list[Path]:
    """The compiled kernels' abi3 wheel for each platform that can be built here (see the
    module docstring); the others are named on stdout."""
    cargo = _cargo()
    if cargo is None:
        print("kernels: no cargo here: no compiled kernels in the zips (the numpy kernels run)")
        return []
    if importlib.util.find_spec("maturin") is not None:
        maturin = [sys.executable, "-m", "maturin"]
    elif shutil.which("maturin"):
        maturin = [shutil.which("maturin")]
    else:
        print("kernels: maturin is not installed (requirements/*.txt): no compiled kernels in "
              "the zips (the numpy kernels run)")
        return []
    zig = _zig_available()
    targets = _rust_targets(cargo)
    env = dict(os.environ, PATH=os.environ.get("PATH", "") + os.pathsep + str(Path(cargo).parent))
    wheels = []
    for platform in platforms:
        target = KERNEL_TARGETS[platform]
        if target not in targets or (platform != "linux-x64" and not zig):
            why = (f"the Rust target {target} is not installed (rustup target add {target})"
                   if target not in targets else "cross-building needs ziglang (pip install)")
            print(f"kernels: {why}: the {platform} zip runs the numpy kernels")
            continue
        dest = out_dir / "kernels" / platform
        shutil.rmtree(dest, ignore_errors=True)
        cmd = [*maturin, "build", "--release", "--quiet",
               "--manifest-path", str(KERNELS_DIR / "Cargo.toml"),
               "--interpreter", sys.executable, "-o", str(dest)]
        if target != _host_target(cargo):  # the host's: make kernels' build is reused
            cmd += ["--target", target]
        if zig:  # Linux: glibc 2.28, as Blender 4.2+ requires
            cmd.append("--zig")
            if platform == "linux-x64":
                cmd += ["--compatibility", "manylinux_2_28"]
        else:
            print(f"kernels: no zig (pip install ziglang): the {platform} wheel needs this "
                  "machine's glibc or newer; where it does not load, the numpy kernels run")
        print(f"kernels: building the {platform} wheel ({' '.join(cmd)})", flush=True)
        done = subprocess.run(cmd, env=env, stdin=subprocess.DEVNULL)
        found = sorted(dest.glob("blisk_cam_kernels-*.whl"))
        if done.returncode != 0 or len(found) != 1:
            raise BuildError(f"maturin could not build the kernels for {platform} "
                             f"(exit {done.returncode}); --no-kernels leaves them out")
        check_kernel_binary(found[0], platform)
        wheels.append(found[0])
    return wheels


def check_kernel_binary(wheel: Path, platform: str) -> None:
    """Refuse a kernels wheel whose extension is not a binary for ``platform``: an x86-64 ELF
    (Linux), an arm64 Mach-O (macOS) or an x86-64 PE DLL importing ``python3.dll`` (Windows,
    the stable ABI that lets one wheel serve Python 3.11 and 3.13), exporting the module's
    ``PyInit_blisk_cam_kernels``."""
    suffix = {"linux-x64": ".so", "macos-arm64": ".so", "windows-x64": ".pyd"}[platform]
    with zipfile.ZipFile(wheel) as zf:
        names = [n for n in zf.namelist() if n.startswith("blisk_cam_kernels/")
                 and n.endswith(suffix)]
        if len(names) != 1:
            raise BuildError(f"{wheel.name}: expected one blisk_cam_kernels/*{suffix}, found "
                             f"{names or 'none'}")
        data = zf.read(names[0])
    if platform == "linux-x64":
        ok = (data[:4] == b"\x7fELF" and data[4] == 2
              and struct.unpack_from("<H", data, 18)[0] == 0x3E)  # EM_X86_64
        what = "an x86-64 ELF shared object"
    elif platform == "macos-arm64":
        ok = (data[:4] == b"\xcf\xfa\xed\xfe"
              and struct.unpack_from("<I", data, 4)[0] == 0x0100000C)  # CPU_TYPE_ARM64
        what = "an arm64 Mach-O"
    else:
        pe = struct.unpack_from("<I", data, 0x3C)[0] if data[:2] == b"MZ" else 0
        ok = (pe and data[pe:pe + 4] == b"PE\0\0"
              and struct.unpack_from("<H", data, pe + 4)[0] == 0x8664
              and b"python3.dll" in data)
        what = "an x86-64 Windows DLL importing python3.dll"
    if ok and b"PyInit_blisk_cam_kernels" not in data:
        ok, what = False, "a Python module (no PyInit_blisk_cam_kernels symbol)"
    if not ok:
        raise BuildError(f"{wheel.name}: {names[0]} is not {what}; the {platform} zip would not "
                         "load it (check the Rust target and the zig install)")


def manifest_with_wheels(text: str, wheels: list[str], platforms: list[str]) -> str:
    """Insert top-level ``wheels``/``platforms`` keys before the first table of the manifest."""
    data = tomllib.loads(text)
    if "wheels" in data or "platforms" in data:
        raise BuildError(
            f"{MANIFEST} must not declare wheels/platforms: they are written at package time"
        )
    lines = text.splitlines(keepends=True)
    first_table = next((i for i, line in enumerate(lines) if re.match(r"\s*\[", line)), len(lines))
    block = ["# Written by scripts/build_extension.py (build copy only).\n"]
    block.append("platforms = [" + ", ".join(f'"{p}"' for p in platforms) + "]\n")
    block.append("wheels = [\n" + "".join(f'    "{w}",\n' for w in wheels) + "]\n\n")
    new_text = "".join(lines[:first_table] + block + lines[first_table:])
    parsed = tomllib.loads(new_text)  # fail here, not in Blender, if the result is not TOML
    if parsed.get("wheels") != wheels:
        raise BuildError("internal error: wheels list did not land at the manifest's top level")
    return new_text


def stage(staging: Path, wheels: list[Path], platforms: list[str]) -> None:
    if staging.exists():
        shutil.rmtree(staging)
    shutil.copytree(PACKAGE_DIR, staging, ignore=STAGING_IGNORE)
    if wheels:
        (staging / "wheels").mkdir()
        for wheel in wheels:
            target = staging / "wheels" / wheel.name
            try:
                os.link(wheel, target)
            except OSError:
                shutil.copy2(wheel, target)
        text = (PACKAGE_DIR / MANIFEST).read_text(encoding="utf-8")
        rel = [f"./wheels/{w.name}" for w in wheels]
        (staging / MANIFEST).write_text(manifest_with_wheels(text, rel, platforms), "utf-8")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--output-dir", default=str(ROOT / "dist"), help="where the zip goes (default: dist/)"
    )
    parser.add_argument(
        "--output-filepath", default=None, help="exact zip path (overrides --output-dir)"
    )
    parser.add_argument(
        "--no-wheels",
        action="store_true",
        help="build without scipy wheels (for tests; Blender must provide scipy)",
    )
    parser.add_argument(
        "--no-kernels",
        action="store_true",
        help="leave the compiled kernels out (the zip runs the numpy kernels)",
    )
    parser.add_argument(
        "--platform",
        dest="platforms",
        action="append",
        choices=sorted(PLATFORMS),
        help="Blender platform to bundle scipy for (repeatable; default: all)",
    )
    parser.add_argument(
        "--python",
        dest="pythons",
        action="append",
        choices=sorted(SCIPY_FOR_PYTHON),
        help="Blender Python version to bundle scipy for (repeatable; default: all)",
    )
    split = parser.add_mutually_exclusive_group()
    split.add_argument(
        "--split-platforms",
        dest="split_platforms",
        action="store_const",
        const=True,
        default=None,
        help="one zip per platform (the default when bundling wheels for several platforms)",
    )
    split.add_argument(
        "--one-zip",
        dest="split_platforms",
        action="store_const",
        const=False,
        help="one zip with the wheels of every platform (large: ~210 MB for all of them)",
    )
    parser.add_argument(
        "--wheels-dir",
        default=str(PACKAGE_DIR / "wheels"),
        help="download cache for the wheels (default: blisk_cam/wheels)",
    )
    parser.add_argument(
        "--staging-dir",
        default=str(ROOT / "build" / "extension" / "blisk_cam"),
        help="build copy of the package (default: build/extension/blisk_cam)",
    )
    parser.add_argument(
        "--blender-ext",
        default=None,
        help="path to blender_ext.py (default: found in the installed bpy wheel)",
    )
    args = parser.parse_args(argv)

    platforms = args.platforms or list(PLATFORMS)
    pythons = args.pythons or list(SCIPY_FOR_PYTHON)
    try:
        args.split_platforms = resolve_split(args, platforms)
        blender_ext = find_blender_ext(args.blender_ext)
        if not (PACKAGE_DIR / MANIFEST).is_file():
            raise BuildError(f"{PACKAGE_DIR / MANIFEST} is missing")
        wheels = (
            [] if args.no_wheels else download_wheels(Path(args.wheels_dir), platforms, pythons)
        )
        if not (args.no_wheels or args.no_kernels):
            wheels += build_kernel_wheels(Path(args.wheels_dir), platforms)
        staging = Path(args.staging_dir)
        stage(staging, wheels, platforms)

        cmd = [sys.executable, str(blender_ext), "build", "--source-dir", str(staging)]
        if args.output_filepath:
            out = Path(args.output_filepath)
            out.parent.mkdir(parents=True, exist_ok=True)
            cmd += ["--output-filepath", str(out)]
        else:
            out_dir = Path(args.output_dir)
            out_dir.mkdir(parents=True, exist_ok=True)
            cmd += ["--output-dir", str(out_dir)]
        if args.split_platforms:
            cmd.append("--split-platforms")
        run(cmd, "blender_ext.py build")
        for zip_path in expected_outputs(args, platforms):
            if not zip_path.is_file():
                raise BuildError(f"blender_ext.py build reported success but {zip_path} is missing")
            run(
                [sys.executable, str(blender_ext), "validate", str(zip_path)],
                f"blender_ext.py validate {zip_path.name}",
            )
            print(f"built {zip_path} ({zip_path.stat().st_size / 1e6:.1f} MB)")
    except BuildError as exc:
        print(f"build_extension: error: {exc}", file=sys.stderr)
        return 1
    return 0


def resolve_split(args, platforms: list[str]) -> bool:
    """One zip per platform? ``--split-platforms`` / ``--one-zip`` when given (BuildError for
    ``--split-platforms`` without wheels); by default yes when wheels are bundled for more
    than one platform."""
    if args.split_platforms is True and args.no_wheels:
        raise BuildError("--split-platforms needs the wheels (drop --no-wheels)")
    if args.split_platforms is None:
        return not args.no_wheels and len(set(platforms)) > 1
    return bool(args.split_platforms)


def expected_outputs(args, platforms: list[str]) -> list[Path]:
    """The zip files blender_ext.py writes (its naming: ``<id>-<version>[-<platform>].zip``)."""
    manifest = tomllib.loads((PACKAGE_DIR / MANIFEST).read_text(encoding="utf-8"))
    if args.output_filepath:
        out = Path(args.output_filepath)
        if not args.split_platforms:
            return [out]
        return [out.with_name(f"{out.stem}-{p.replace('-', '_')}{out.suffix}") for p in platforms]
    stem = f"{manifest['id']}-{manifest['version']}"
    out_dir = Path(args.output_dir)
    if not args.split_platforms:
        return [out_dir / f"{stem}.zip"]
    return [out_dir / f"{stem}-{p.replace('-', '_')}.zip" for p in platforms]


if __name__ == "__main__":
    sys.exit(main())
