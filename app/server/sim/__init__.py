"""The simulation thread of `artro serve` and its parts: pacing, typed commands, the live robot
and its drive, the ghost, the paths, the gait ramp, what it publishes (docs/DESIGN.md §10)."""
