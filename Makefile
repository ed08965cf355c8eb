# Blisk CAM — developer commands. Everything runs in two virtual environments that are
# created on first use and re-synced only when their requirements file changes:
#   .venv/bpy45  Python 3.11, bpy 4.5 (Blender 4.2–5.0 line), numpy 1.26
#   .venv/bpy52  Python 3.13, bpy 5.2 (Blender 5.1+ line), numpy 2.x
#
#   make demo      demo blisk → demo_out/demo.blend, demo_out/preview.png
#   make test      tests/core (plain pytest), tests/blender under bpy 4.5 and bpy 5.2
#   make bench     every bench/*.py
#   make kernels   build the compiled kernels (kernels/, Rust) and install them into both venvs
#   make package   dist/blisk_cam-<version>-<platform>.zip, one per platform, with its scipy wheels
#   make package-all  dist/blisk_cam-<version>.zip, one zip with the wheels of every platform
#   make check-windows  the Windows zip installed into Windows Blender 4.5 under Wine (wine64)
#   make lint      ruff check

SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
.DEFAULT_GOAL := help

PY311 ?= python3.11
# pyenv installs 3.13 beside the default 3.11; elsewhere python3.13 is on PATH.
PY313 ?= $(shell if PYENV_VERSION=3.13.0 python3.13 -c '' >/dev/null 2>&1; \
                 then echo 'env PYENV_VERSION=3.13.0 python3.13'; else echo python3.13; fi)

VENV45 := .venv/bpy45
VENV52 := .venv/bpy52
REQ45 := requirements/bpy45.txt
REQ52 := requirements/bpy52.txt
# make package's own venv: zig (ziglang) for the cross-built kernels wheels, kept out of the
# test venvs so that a test's Linux wheel reuses make kernels' build.
VENVPKG := .venv/package
REQPKG := requirements/package.txt
# The Rust targets of the macOS arm64 and Windows x64 kernels wheels.
PACKAGE_RUST_TARGETS := aarch64-apple-darwin x86_64-pc-windows-gnu

# Per-process time limits (a hang, e.g. bpy 4.5 at exit with classes still registered,
# fails the run instead of blocking it).
TIMEOUT_CORE ?= 30m
TIMEOUT_BLENDER ?= 15m
TIMEOUT_BENCH ?= 20m
TIMEOUT := timeout --kill-after=30s

PYTEST_FLAGS ?=

# $(call ensure_venv,DIR,PYTHON,REQUIREMENTS): create DIR if missing, pip install when the
# requirements file's hash differs from the stamp (a no-op taking milliseconds otherwise).
define ensure_venv
	@want="$$(sha256sum $(3) | cut -c1-16)"; \
	stamp="$(1)/.blisk_cam-requirements"; \
	if [ -x "$(1)/bin/python" ] && "$(1)/bin/python" -c '' 2>/dev/null \
	   && [ "$$(cat "$$stamp" 2>/dev/null)" = "$$want" ]; then exit 0; fi; \
	if ! [ -x "$(1)/bin/python" ] || ! "$(1)/bin/python" -c '' 2>/dev/null; then \
	  echo "creating $(1) with $(2)"; rm -rf "$(1)"; $(2) -m venv "$(1)"; \
	fi; \
	echo "installing $(3) into $(1)"; \
	"$(1)/bin/python" -m pip install --disable-pip-version-check --no-input -q -r $(3); \
	echo "$$want" > "$$stamp"
endef

# The compiled kernels (kernels/: Rust, PyO3 abi3 — one wheel for Python 3.11 and 3.13), built
# with maturin (from the requirements) into build/kernels/<hash>/ and installed into a venv
# when the hash of kernels/'s sources differs from the venv's stamp. Without cargo (PATH or
# ~/.cargo/bin) nothing is built: the numpy kernels run, and say so in one line.
KERNEL_SRC = kernels/Cargo.toml kernels/Cargo.lock kernels/pyproject.toml $(sort $(wildcard kernels/src/*.rs))
CARGO_HOME_BIN ?= $(HOME)/.cargo/bin

# $(call ensure_kernels,VENV)
define ensure_kernels
	@want="$$(cat $(KERNEL_SRC) | sha256sum | cut -c1-16)"; \
	stamp="$(1)/.blisk_cam-kernels"; \
	if [ "$$(cat "$$stamp" 2>/dev/null)" = "$$want" ]; then exit 0; fi; \
	export PATH="$$PATH:$(CARGO_HOME_BIN)"; \
	if ! command -v cargo >/dev/null 2>&1; then \
	  echo "kernels: cargo not found (PATH, $(CARGO_HOME_BIN)): not built; the numpy kernels run"; \
	  exit 0; fi; \
	out="build/kernels/$$want"; \
	if ! ls "$$out"/blisk_cam_kernels-*.whl >/dev/null 2>&1; then \
	  echo "kernels: building the compiled kernels (cargo, maturin; a clean build takes minutes)"; \
	  rm -rf "$$out"; \
	  "$(1)/bin/maturin" build --release --quiet --manifest-path kernels/Cargo.toml \
	    -i "$(1)/bin/python" -o "$$out"; \
	fi; \
	"$(1)/bin/python" -m pip install --disable-pip-version-check --no-input -q --no-deps \
	  --force-reinstall "$$out"/blisk_cam_kernels-*.whl; \
	echo "$$want" > "$$stamp"; \
	echo "kernels: installed into $(1): $$("$(1)/bin/python" -c \
	  'import blisk_cam_kernels as k; print("compiled", k.VERSION)')"
endef

.PHONY: help venv45 venv52 venvs kernels kernels45 kernels52 demo test test-core test-blender45 test-blender52 bench \
        package package-all package-tools check-windows lint clean

help:
	@sed -n 's/^#   make /  make /p' $(firstword $(MAKEFILE_LIST))

venv45:
	$(call ensure_venv,$(VENV45),$(PY311),$(REQ45))

venv52:
	$(call ensure_venv,$(VENV52),$(PY313),$(REQ52))

venvs: venv45 venv52

kernels45: venv45
	$(call ensure_kernels,$(VENV45))

# the abi3 wheel the first of the two builds serves the other's Python too
kernels52: venv52
	$(call ensure_kernels,$(VENV52))

kernels: kernels45 kernels52

demo: kernels45
	$(VENV45)/bin/python -m blisk_cam demo --out demo_out
	@echo "demo written: $(CURDIR)/demo_out/demo.blend and $(CURDIR)/demo_out/preview.png"

# pytest exits 5 when it collected no test: that fails the target like any other failure.
# tests/core runs on every core (pytest-xdist; TEST_WORKERS=0 runs it in one process).
TEST_WORKERS ?= auto
RUN_CORE = $(TIMEOUT) $(TIMEOUT_CORE) $(VENV45)/bin/python -m pytest tests/core -n $(TEST_WORKERS) $(PYTEST_FLAGS)
RUN_BLENDER45 = $(TIMEOUT) $(TIMEOUT_BLENDER) $(VENV45)/bin/python -m pytest tests/blender $(PYTEST_FLAGS)
RUN_BLENDER52 = $(TIMEOUT) $(TIMEOUT_BLENDER) $(VENV52)/bin/python -m pytest tests/blender $(PYTEST_FLAGS)

# All three runs happen even if one fails; the target fails if any did (a pytest that
# collected no test exits 5, a hang is killed by timeout: both count as failures).
test: kernels
	@failed=""; \
	echo "== tests/core (bpy 4.5 venv): $(RUN_CORE)"; \
	$(RUN_CORE) || failed="$$failed tests/core(exit $$?)"; \
	echo "== tests/blender under bpy 4.5: $(RUN_BLENDER45)"; \
	$(RUN_BLENDER45) || failed="$$failed tests/blender@bpy4.5(exit $$?)"; \
	echo "== tests/blender under bpy 5.2: $(RUN_BLENDER52)"; \
	$(RUN_BLENDER52) || failed="$$failed tests/blender@bpy5.2(exit $$?)"; \
	if [ -n "$$failed" ]; then echo "make test: FAILED:$$failed" >&2; exit 1; fi; \
	echo "make test: all runs passed"

test-core: kernels45
	$(RUN_CORE)

test-blender45: kernels45
	$(RUN_BLENDER45)

test-blender52: kernels52
	$(RUN_BLENDER52)

bench: kernels45
	@shopt -s nullglob; files=(bench/*.py); \
	if [ $${#files[@]} -eq 0 ]; then echo "no bench/*.py"; exit 0; fi; \
	for f in "$${files[@]}"; do \
	  echo "== $$f"; \
	  PYTHONPATH="$(CURDIR)" $(TIMEOUT) $(TIMEOUT_BENCH) $(VENV45)/bin/python "$$f"; \
	done

# zig on PATH as python3 -m ziglang (the package venv first), the Rust targets added when
# rustup is here (without them the script says which zip runs the numpy kernels).
package-tools:
	$(call ensure_venv,$(VENVPKG),$(PY311),$(REQPKG))
	@export PATH="$$PATH:$(CARGO_HOME_BIN)"; \
	if command -v rustup >/dev/null 2>&1; then \
	  rustup target add $(PACKAGE_RUST_TARGETS) >/dev/null || \
	    echo "rustup could not add $(PACKAGE_RUST_TARGETS): those zips run the numpy kernels"; fi

package: venv45 package-tools
	PATH="$(CURDIR)/$(VENVPKG)/bin:$$PATH:$(CARGO_HOME_BIN)" \
	  $(VENV45)/bin/python scripts/build_extension.py --output-dir dist

package-all: venv45 package-tools
	PATH="$(CURDIR)/$(VENVPKG)/bin:$$PATH:$(CARGO_HOME_BIN)" \
	  $(VENV45)/bin/python scripts/build_extension.py --output-dir dist --one-zip

# The Windows zip installed into Windows Blender 4.5 under Wine (scripts/wine/windows_check.sh;
# needs wine64, not part of make test); --suite also runs tests/core there (~30 min).
check-windows: venv45 package-tools
	scripts/wine/windows_check.sh $(CHECK_WINDOWS_ARGS)

lint: venv45
	$(VENV45)/bin/ruff check .

clean:
	rm -rf build dist demo_out .pytest_cache .hypothesis
