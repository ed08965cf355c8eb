"""Channel roughing geometry: the level surfaces between hub and shroud, the region a cutter
and its body may take on a level between two neighbouring blades (offset by the allowance),
and the roughing patterns on it (paper 003 §5, stage 1: slotting the channel in levels,
leaving 0.5 mm)."""
