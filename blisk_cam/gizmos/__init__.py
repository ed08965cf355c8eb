"""Viewport gizmos (the two cone gizmos). List every class in ``CLASSES``."""

CLASSES = []
