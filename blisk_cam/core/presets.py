"""Presets shipped with the package and the user's own TOML files, read the same way for every
kind (machines in ``blisk_cam/machines``, robots in ``blisk_cam/robots``).

A name without a path separator or ``.toml`` that is not an existing file is a preset; an unknown
preset lists the known ones. The result is the TOML table; turning it into a machine or a robot
(and refusing unknown keys, :func:`.errors.check_known_keys`) is the caller's.
"""

from __future__ import annotations

import os
import tomllib
from pathlib import Path

from .errors import BliskCamError

__all__ = ["preset_names", "read_preset_toml"]


def preset_names(folder: Path) -> list[str]:
    """Names of the ``*.toml`` presets in ``folder``, sorted."""
    return sorted(p.stem for p in Path(folder).glob("*.toml"))


def read_preset_toml(name_or_path, folder: Path, what: str,
                     error: type[BliskCamError] = BliskCamError) -> tuple[dict, Path]:
    """(table, path) of a preset name in ``folder`` or of a TOML file.

    ``what`` names the kind in messages ("machine", "robot"); ``error`` is the error class
    raised: unknown preset (listing the known ones), file not found, invalid TOML."""
    text = os.fspath(name_or_path)
    path = Path(text)
    if not (text.endswith(".toml") or os.sep in text or path.exists()):
        preset = Path(folder) / f"{text}.toml"
        if not preset.exists():
            raise error(f"unknown {what} preset {text!r}; known: "
                        f"{', '.join(preset_names(folder))} (or give a path to a {what} .toml)")
        path = preset
    if not path.is_file():
        raise error(f"{what} file {text} not found")
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh), path
    except tomllib.TOMLDecodeError as err:
        raise error(f"{what} file {path.name} is not valid TOML: {err}") from err
