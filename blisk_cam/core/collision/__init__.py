"""Collisions of the tool body with the blisk (paper 004; floor 6: imports ``paths``
(orientation, linking), ``machine`` and below).

``obstacles`` (blade, neighbours, hub), ``posed_tool`` (the tool assembly at a pose as a
signed-distance body), ``tri_tree`` (obstacle triangles and the refine step), ``scene``
(detection), ``options``, ``avoid`` (the smallest rotation of the tool axis), ``reroute``
(links through the clearance surface), ``report``. mm, radians.
"""
