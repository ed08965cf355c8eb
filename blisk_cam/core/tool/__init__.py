"""The tool (floor 3: imports ``geometry`` and below).

``cutter`` (the generalised milling cutter of DIN 66215: shape, CC → CL, effective radius),
``assembly`` (flute and non-cutting body: shank, holder, the holder profile the user types).
Lengths in mm, angles in radians.
"""
