"""Operators (``blisk_cam.*``): poll, gather inputs, call ``core``, write results, report.

One operator per module; list every class in ``CLASSES`` (registered in this order after the
property groups, unregistered in reverse). Planned bl_idnames (see ARCHITECTURE.md):
``blisk_cam.fit_cones``, ``blisk_cam.generate_paths``, ``blisk_cam.clear_paths``,
``blisk_cam.export_paths``, ``blisk_cam.render_preview``.
"""

CLASSES = []
