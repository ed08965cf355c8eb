"""Errors raised by the core.

Every error names the problem and what the user can do about it; the Blender operators
turn them into ``self.report({'ERROR'}, str(err))`` and the CLI into one line on stderr.
:func:`check_known_keys` is the one check of the keys of a table read from a user's file
(machine TOML and every later one): an unknown key is an error naming it and the nearest
known key, never silently dropped.
"""

import difflib


class BliskCamError(ValueError):
    """Base class of every error the core raises on bad input."""


class MeshError(BliskCamError):
    """The mesh cannot be used (empty, NaN coordinates, bad indices, inconsistent winding...)."""


class ConeError(BliskCamError):
    """The hub/tip cones are unusable (identical, crossing inside the region, missing the blade)."""


class ToleranceError(BliskCamError):
    """A tolerance or tool dimension is non-positive or absurd."""


class ToolError(ToleranceError):
    """The cutter is impossible (corner radius above the tool radius, negative or NaN
    dimensions, taper angle out of range, a corner radius contradicting the tool type...)."""


class OrientationError(BliskCamError):
    """The tool-axis settings are impossible (lead/tilt out of range, contradicting modes)."""


class LinkError(BliskCamError):
    """The linking settings are impossible (unknown mode, non-positive distances)."""


class OptionError(BliskCamError):
    """An option value outside its bounds or choices (names the option and the bounds)."""


class MachineError(BliskCamError):
    """The machine description is unusable (malformed TOML, missing or zero axis, reversed
    limits, unknown kinematics or preset, a part frame whose x and z are not orthogonal)."""


class ReachError(BliskCamError):
    """A pose of the program cannot be reached by the machine (out of a rotary or linear
    limit on every solution branch, or an orientation the rotaries cannot produce)."""


class PostError(BliskCamError):
    """The NC program cannot be written (unknown post, a machine the post does not support,
    an output path in a missing directory)."""


class CollisionError(BliskCamError):
    """Collision checking cannot run: bad blade count/neighbours, an obstacle that contains the
    blade, an impossible tool assembly or collision option."""


class PartError(BliskCamError):
    """The blisk part cannot be built: a mesh that is not rotationally periodic, a blade count
    that does not match the mesh's symmetry, no hub (faces of revolution) found, an unusable
    hub profile."""


class StockError(BliskCamError):
    """The stock cannot be built or used: an unusable blank profile or mesh, a resolution out
    of range, a saved stock state that does not belong to this part."""


def check_known_keys(table, known, where: str, error=BliskCamError) -> None:
    """Raise ``error`` for the first key of the mapping ``table`` that is not in ``known``:
    the message names the key, the nearest known key (:func:`difflib.get_close_matches`, case
    ignored) and ``where`` it is (e.g. ``"machine ac.toml rotary 1 (A)"``)."""
    known = list(known)
    for key in table:
        if key in known:
            continue
        lower = {k.lower(): k for k in known}
        close = difflib.get_close_matches(str(key).lower(), list(lower), n=1, cutoff=0.5)
        hint = (f"did you mean {lower[close[0]]!r}?" if close
                else f"known keys: {', '.join(known)}")
        raise error(f"{where}: unknown key {key!r}; {hint} (an unknown key would be ignored, "
                    "so it is refused)")
