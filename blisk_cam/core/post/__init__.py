"""NC post-processors: one module per controller dialect over one block stream
(:mod:`.blocks`). ``POSTS`` names them; :func:`get_post` returns the module, which has
``NAME``, ``TCP`` (X Y Z in the paths' frame), ``INDEXABLE`` (blades by subprogram call),
``check(machine)`` (PostError when the post cannot drive the machine) and
``write(ctx) -> str``."""

from __future__ import annotations

import importlib

from ..errors import PostError

__all__ = ["POSTS", "get_post"]

POSTS = ("linuxcnc", "fanuc", "siemens", "heidenhain", "apt")


def get_post(name: str):
    """The post module called ``name`` (PostError listing the known posts)."""
    key = str(name).strip().lower()
    if key not in POSTS:
        raise PostError(f"unknown post {name!r}; known: {', '.join(POSTS)}")
    return importlib.import_module(f".{key}", __name__)
