"""Command-line flags generated from the option declarations (:mod:`blisk_cam.core.options`):
one flag per option with its help, unit and default (angles in degrees), and the parsed values
back in core units, checked with the declared bounds. Used by every command of the CLI."""

from __future__ import annotations

import argparse
import math
import os
import sys

from ..core.errors import BliskCamError
from ..core.options import check_value, fields, from_user, to_user

__all__ = ["PROG", "CliInternalError", "UsageError", "add_option_flags", "add_threads_argument",
           "check_file_roles", "finite", "option_args", "positive", "threads"]


class UsageError(BliskCamError):
    """Bad command line (unknown option, missing or malformed argument)."""


def finite(text):
    """argparse type: a finite number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got '{text}'") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got '{text}'")
    return value


def _same_file(a: str, b: str) -> bool:
    """Whether two file names are one file: the same resolved path, or (both existing) the
    same inode (a hard or symbolic link, another spelling)."""
    ra, rb = os.path.realpath(os.path.expanduser(a)), os.path.realpath(os.path.expanduser(b))
    if os.path.normcase(ra) == os.path.normcase(rb):
        return True
    try:
        return os.path.samefile(ra, rb)
    except OSError:
        return False


def add_part_arguments(parser) -> None:
    """The part's flags of the commands that read a blisk (``simulate``, ``rough``, ``hub``):
    ``--part`` (the whole blisk, or one blade with ``--hub-profile``) and ``--blade-count``."""
    parser.add_argument("--part", required=True, metavar="MESH",
                        help="the whole blisk (.stl/.obj/.ply, mm), or one blade with "
                        "--hub-profile")
    parser.add_argument("--hub-profile", metavar="CSV", default=None,
                        help="hub generatrix 'r, z' per line (mm): --part is then one blade")
    parser.add_argument("--blade-count", required=True, type=int, metavar="N",
                        help="number of blades (checked against the mesh's symmetry)")


def check_file_roles(inputs, outputs) -> None:
    """UsageError, before any work, when an output file is an input file or another output:
    ``inputs`` and ``outputs`` are ``[(flag, file name or None)]``. Nothing the user owns is
    overwritten by a slip of ``--out``."""
    ins = [(f, v) for f, v in inputs if v]
    outs = [(f, v) for f, v in outputs if v]
    for k, (flag, name) in enumerate(outs):
        for iflag, iname in ins:
            if _same_file(name, iname):
                raise UsageError(f"{flag} {name} is the input {iflag}: it would be overwritten; "
                                 f"choose another output name")
        for oflag, oname in outs[:k]:
            if _same_file(name, oname):
                raise UsageError(f"{flag} {name} is also {oflag}: one would replace the other; "
                                 "give each output its own name")


def positive(text):
    """argparse type: a finite number > 0."""
    value = finite(text)
    if value <= 0.0:
        raise argparse.ArgumentTypeError(f"expected a number > 0, got '{text}'")
    return value


def whole(text):
    """argparse type: a whole number."""
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got '{text}'") from None


def threads(text):
    """argparse type of ``--threads``: a whole number ≥ 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a whole number of threads (1 or more), got '{text}'") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected 1 or more threads, got {value}")
    return value


def add_threads_argument(parser) -> None:
    """``--threads N`` of every command that computes: the threads of the compiled kernels
    (rayon) and of the chunked queries (:func:`..core.runtime.parallel`); default every core
    this process may use. The results do not depend on it."""
    from ..core.runtime import default_workers

    parser.add_argument("--threads", type=threads, default=None, metavar="N",
                        help=f"threads of the computation (default: every core, "
                        f"{default_workers()} here); the results do not depend on it")


def add_option_flags(parser, stages):
    """One flag per declared option of ``stages``: help, unit and default from the
    declaration; angles in degrees. Every flag defaults to None ("not given": the declared
    default applies); :func:`option_args` converts and checks."""
    for stage in stages:
        group = parser.add_argument_group(stage.title or stage.__name__)
        for name, spec, default in fields(stage):
            flag = spec.cli_flag(name)
            if flag is None:
                continue
            shown = to_user(spec, default)
            unit = {"deg": " degrees", "": ""}.get(spec.unit, f" {spec.unit}")
            if spec.choices is not None:
                words = [c.cli_word for c in spec.choices]
                text = f"{spec.help} (default {spec.choice(default).cli_word})"
                group.add_argument(flag, dest=name, type=str.lower, choices=words,
                                   default=None, help=text)
            elif isinstance(default, bool):
                text = f"{spec.help} (default {'on' if default else 'off'})"
                group.add_argument(flag, dest=name, action=argparse.BooleanOptionalAction,
                                   default=None, help=text)
            elif isinstance(default, int):
                group.add_argument(flag, dest=name, type=whole, default=None, metavar="N",
                                   help=f"{spec.help} (default {default})")
            else:
                text = spec.help if shown is None else f"{spec.help} (default {shown:g}{unit})"
                metavar = ("DEG" if spec.unit == "deg" else "MM" if spec.unit == "mm"
                           else "N" if spec.unit == "" else spec.unit.upper().replace("/", "_"))
                if spec.size > 1:
                    names = ("X", "Y", "Z") if spec.size == 3 else (metavar,) * spec.size
                    group.add_argument(flag, dest=name, type=finite, default=None, help=text,
                                       nargs=spec.size, metavar=names)
                else:
                    group.add_argument(flag, dest=name, type=finite, default=None, help=text,
                                       metavar=metavar)


def option_args(args, stages) -> dict:
    """{option: core value} of the flags given (not None), in core units (radians), each
    checked against its declaration (UsageError naming the flag and the bounds)."""
    given = {}
    for stage in stages:
        for name, spec, default in fields(stage):
            value = getattr(args, name, None)
            if value is None or spec.cli_flag(name) is None:
                continue
            if spec.choices is not None:
                value = next(c.value for c in spec.choices if c.cli_word == value)
            elif isinstance(value, list):
                value = tuple(float(v) for v in value)
            elif not isinstance(value, (bool, int)):
                value = from_user(spec, float(value))
            if default is None and spec.none_as is not None and value == spec.none_as:
                value = None  # "0: automatic"
            try:
                check_value(name, spec, value, UsageError)
            except UsageError as exc:
                raise UsageError(f"argument {exc}") from None
            if value is not None:
                given[name] = value
    return given


#: the program name in messages (``blisk_cam: error: ...``)
PROG = "blisk_cam"


class CliInternalError(Exception):
    """An operator failed on something that is not bad input (exit status 3)."""


# --- entry point -------------------------------------------------------------------------
def _one_line(text) -> str:
    return " ".join(str(text).split()) or "unknown error"


def _fail(message) -> None:
    sys.stdout.flush()
    print(f"{PROG}: error: {_one_line(message)}", file=sys.stderr, flush=True)
