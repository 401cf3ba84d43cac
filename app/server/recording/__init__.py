"""Record and replay: the recorder's rings, a replay, a recording file read strictly, the sensor
trace (docs/DESIGN.md §10, §14)."""
