"""The hub as a surface to finish (floor 5): the hub surface of revolution, the channel
between two blades at the hub with its boundary-conformed passes, and the fillet passes."""
