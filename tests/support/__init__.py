"""What the tests and the benchmarks share: the test blades (``blades``: NASA Rotor 37/67 of
tests/data/blades with their cones, and a small analytic blade), mesh files written from arrays
(``mesh_files``: binary/ASCII STL, OBJ, PLY, and a triangle oracle), and the NC programs read
back (``nc``: one parser per dialect, LinuxCNC's rs274, the paths the posts are tested on).

Imported as ``tests.support.<module>`` (pytest's ``pythonpath`` and the bench scripts put the
repository root on ``sys.path``); none of it is collected as tests."""
