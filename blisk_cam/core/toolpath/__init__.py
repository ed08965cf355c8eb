"""What a tool path is (floor 4: imports ``tool``, ``part`` and below).

``types`` (PassCurve, Program, ToolPath; the MOVE_, FLAG_ and STATUS_ codes), ``paths_io``
(the paths JSON, version 1, ``docs/paths-json.md``). Every operation produces these; every
checker, post and front end reads them.
"""
