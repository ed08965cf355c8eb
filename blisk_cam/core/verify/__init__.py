"""The independent checker (floor 5: imports ``toolpath`` and below; never ``paths`` or
``process``: the checker does not use the generator it checks).

``measure`` (verify a tool path on its mesh: scallops, gouges, chord errors), ``samples``
(surface samples of the machined region), ``sweep``, ``sweep_ball``, ``forest`` (volumes swept
by the cutter), ``verdict`` (PASS/FAIL per bound, and where). mm.
"""
