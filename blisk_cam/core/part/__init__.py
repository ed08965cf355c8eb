"""The part (floor 3: imports ``geometry`` and below).

``cones`` (cones about the blisk axis and the linear morphing cone, paper 001 §2),
``profiles`` (profile generatrices and the linear morphing revolution surfaces), ``fitting``
(hub and tip generatrices fitted to a blade's boundary loops), ``blisk`` and
``blisk_params`` (the parametric blisk and its validated parameters). mm, radians.
"""
