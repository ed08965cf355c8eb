"""The in-process stock: radial dexels of one pitch sector (``dexels``), the blank it starts
from (``blank``), material removal by a program's moves with crash detection (``removal``)
and the deviation map on the part that is the verdict (``deviation``). Floor 5: imports
errors, runtime, geometry, tool, part and toolpath."""
