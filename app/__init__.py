"""ArtRo Gait Studio: robots, worlds, the simulation, evaluations, analysis, firmware, parameter
sets, the dashboard server, studies and the `artro` command, one package each (docs/DESIGN.md
§2)."""
