"""Shared checks of the TCP posts (X Y Z in the paths' frame)."""

from __future__ import annotations

from ..errors import PostError


def check_tcp(machine, post: str):
    """A TCP post writes the paths' coordinates in a work offset at the part origin with the
    part's axes: the machine's [part] frame must be the identity (else the controller's
    frame rotation would have to be written, which this post does not do)."""
    if not machine.part_is_identity:
        raise PostError(
            f"post {post}: the machine {machine.name!r} has a turned or shifted [part] frame; "
            "TCP programs here need the work offset at the part origin with the part's axes "
            "([part] origin = [0, 0, 0], x = [1, 0, 0], z = [0, 0, 1]), or use post linuxcnc"
        )
