"""Background jobs of `artro serve`: the one job registry and every kind of job (axle fit, CA
calibration, robustness, tune, robot import), each given the registry (docs/DESIGN.md §10)."""
