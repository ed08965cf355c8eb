"""Shared checks of the TCP posts (X Y Z in the paths' frame)."""

from __future__ import annotations

import numpy as np

from ..errors import PostError


def check_tcp(machine, post: str):
    """A TCP post writes the paths' coordinates in a work offset at the part origin with the
    part's axes. The part origin may sit anywhere (the header states the work offset to set:
    the controller's TCP adds it); the [part] axes must be the machine's (else the
    controller's frame rotation would have to be written, which this post does not do)."""
    if not np.allclose(machine.part_rotation, np.eye(3), atol=1e-12):
        raise PostError(
            f"post {post}: the machine {machine.name!r} has a turned [part] frame; TCP "
            "programs here need the part's axes along the machine's ([part] x = [1, 0, 0], "
            "z = [0, 0, 1]; the origin may be anywhere), or use post linuxcnc"
        )
