"""Worlds a robot walks in: model variations (physics, servos, floor, calibration), their default
ranges and seeded samples, and the servo play that latency and backlash put on the set-points
(docs/DESIGN.md §8)."""
