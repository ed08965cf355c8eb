"""The command line, ``python -m blisk_cam`` (a front end over ``core``; may import the
Blender side, which never imports it).

``main`` (the parser and dispatch), ``flags`` (flags generated from the option
declarations, usage errors), ``paths`` and ``nc`` (numpy/scipy only), ``blender`` (the only
module here that imports bpy: the ``demo`` command and the Blender outputs).
"""
