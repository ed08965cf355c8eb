"""LMC finishing of a blade (paper 001; floor 5: imports ``toolpath`` and below, never
``verify``, ``collision`` or ``process``).

``slicing`` (mesh ∩ LMC), ``sampling`` (chord-error forward step), ``expansion`` (the next
ratio from the cusp height), ``spacing`` (the spacing radius of a cutter on a surface),
``passes`` (the boundary-conformed passes), ``orientation`` (tool axes from lead/tilt),
``gouge`` (local gouge check and fix), ``linking`` (order, spiral, moves between passes).
"""
