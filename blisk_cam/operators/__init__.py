"""Operators (``blisk_cam.*``): poll, gather inputs, call ``core``, write results, report.

One operator per module; list every class in ``CLASSES`` (registered in this order after the
property groups, unregistered in reverse). bl_idnames (see ARCHITECTURE.md):
``blisk_cam.fit_cones``, ``blisk_cam.generate_paths``, ``blisk_cam.clear_paths``,
``blisk_cam.export_paths``, ``blisk_cam.render_preview``,
``blisk_cam.export_nc``, ``blisk_cam.check_collisions``,
``blisk_cam.next_unresolved_pose``, ``blisk_cam.animate_program``,
``blisk_cam.per_blade_paths``, ``blisk_cam.load_blade_results``, ``blisk_cam.export_robot``,
``blisk_cam.show_robot``, ``blisk_cam.simulate_stock``, the Operations panel's
``blisk_cam.operation_add``/``_remove``/``_move``, ``blisk_cam.tool_add``/``_remove``,
``blisk_cam.generate_all`` and ``blisk_cam.export_job``. Shared helpers (poll reasons,
settings → core request, error reports) are in :mod:`.common`.
"""

from .animate_program import BLISKCAM_OT_animate_program
from .check_collisions import BLISKCAM_OT_check_collisions
from .clear_paths import BLISKCAM_OT_clear_paths
from .export_job import BLISKCAM_OT_export_job
from .export_nc import BLISKCAM_OT_export_nc
from .export_paths import BLISKCAM_OT_export_paths
from .export_robot import BLISKCAM_OT_export_robot
from .fit_cones import BLISKCAM_OT_fit_cones
from .generate_all import BLISKCAM_OT_generate_all
from .generate_paths import BLISKCAM_OT_generate_paths
from .next_unresolved_pose import BLISKCAM_OT_next_unresolved_pose
from .operations_list import (
    BLISKCAM_OT_operation_add,
    BLISKCAM_OT_operation_move,
    BLISKCAM_OT_operation_remove,
    BLISKCAM_OT_tool_add,
    BLISKCAM_OT_tool_remove,
)
from .per_blade_paths import BLISKCAM_OT_load_blade_results, BLISKCAM_OT_per_blade_paths
from .render_preview import BLISKCAM_OT_render_preview
from .set_scene_mm import BLISKCAM_OT_set_scene_mm
from .show_robot import BLISKCAM_OT_show_robot
from .simulate_stock import BLISKCAM_OT_simulate_stock

CLASSES = [
    BLISKCAM_OT_fit_cones,
    BLISKCAM_OT_generate_paths,
    BLISKCAM_OT_clear_paths,
    BLISKCAM_OT_export_paths,
    BLISKCAM_OT_render_preview,
    BLISKCAM_OT_export_nc,
    BLISKCAM_OT_set_scene_mm,
    BLISKCAM_OT_check_collisions,
    BLISKCAM_OT_next_unresolved_pose,
    BLISKCAM_OT_animate_program,
    BLISKCAM_OT_per_blade_paths,
    BLISKCAM_OT_load_blade_results,
    BLISKCAM_OT_export_robot,
    BLISKCAM_OT_show_robot,
    BLISKCAM_OT_simulate_stock,
    BLISKCAM_OT_operation_add,
    BLISKCAM_OT_operation_remove,
    BLISKCAM_OT_operation_move,
    BLISKCAM_OT_tool_add,
    BLISKCAM_OT_tool_remove,
    BLISKCAM_OT_generate_all,
    BLISKCAM_OT_export_job,
]
