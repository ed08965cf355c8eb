"""Helpers the Blender side shares: operators, panels, gizmos and the CLI's Blender commands
use them; they import ``core`` and ``bpy``, never ``cli`` or ``batch``.

``objects`` (mesh files and objects ↔ arrays), ``path_objects`` and ``collision_objects``
(the objects that show a result), ``render`` (still previews), ``units`` (scene units),
``settings`` (scene settings ↔ core requests, statistics), ``demo_scene``.
"""
