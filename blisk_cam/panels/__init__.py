"""Sidebar panels: 3D viewport, N-panel tab "Blisk CAM".

One module per panel group; list every class in ``CLASSES`` in display order (parents before
their sub-panels).
"""

from .collisions import BLISKCAM_PT_collisions
from .operations import (
    BLISKCAM_PT_operations,
    BLISKCAM_PT_tool_table,
    BLISKCAM_UL_job_tools,
    BLISKCAM_UL_operations,
)
from .paths import BLISKCAM_PT_display, BLISKCAM_PT_machine, BLISKCAM_PT_paths, BLISKCAM_PT_preview
from .per_blade import BLISKCAM_PT_per_blade
from .robot import BLISKCAM_PT_robot
from .setup import BLISKCAM_PT_region, BLISKCAM_PT_setup, BLISKCAM_PT_tolerances, BLISKCAM_PT_tool
from .stock import BLISKCAM_PT_stock

CLASSES = [
    BLISKCAM_UL_operations,
    BLISKCAM_UL_job_tools,
    BLISKCAM_PT_setup,
    BLISKCAM_PT_region,
    BLISKCAM_PT_tool,
    BLISKCAM_PT_tolerances,
    BLISKCAM_PT_paths,
    BLISKCAM_PT_display,
    BLISKCAM_PT_collisions,
    BLISKCAM_PT_stock,
    BLISKCAM_PT_operations,
    BLISKCAM_PT_tool_table,
    BLISKCAM_PT_per_blade,
    BLISKCAM_PT_machine,
    BLISKCAM_PT_robot,
    BLISKCAM_PT_preview,
]
