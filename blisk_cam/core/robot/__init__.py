"""The robot cell (paper 004's polishing robot): the 6R arm with an ortho-parallel basis and a
spherical wrist (OPW) read from TOML, its forward and closed-form inverse kinematics, the free
angle about the tool axis resolved over a path, and the robot programs (KUKA KRL, ABB RAPID,
Comau PDL2, Fanuc LS). Floor 6: imports errors, geometry, toolpath and post.common only."""
