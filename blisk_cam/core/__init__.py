"""The core: pure numpy/scipy, no bpy, bmesh or mathutils; arrays and dataclasses in and out.

One package per concept of the papers, on floors that only import downward
(``docs/ARCHITECTURE.md``; ``tests/core/test_import_graph.py`` holds the rules):

1. ``errors``, ``version``, ``runtime`` (threads, cancellation)
2. ``options`` (user options, declared once), ``geometry/``
3. ``tool/`` (cutters, tool assembly), ``part/`` (cones, profiles, fitting, the blisk)
4. ``toolpath/`` (result types, the paths JSON)
5. ``paths/`` (LMC finishing), ``verify/`` (the independent checker), ``machine/``
6. ``collision/``, ``post/``
7. ``process/`` (operations), ``display`` (display values of a result)

Nothing in core imports outside core. Import the module you need; this package exports
nothing.
"""
