"""The simulation core: the robot model, the frame loop, metrics, headless and batch runs.

Imports `gait`, `hardware` and mujoco only (docs/DESIGN.md §2).
"""
