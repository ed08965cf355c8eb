"""5-axis machine tools (floor 5: imports ``toolpath`` and below).

``description`` (machine TOML and forward kinematics), ``kinematics`` (inverse kinematics,
linearisation), ``block_error`` (theoretical machining error of a block, paper 002),
``block_search`` and ``interpolation`` (constant-error NC blocks), ``motion`` (the machine's
motion along a program, to animate). mm, radians.
"""
