"""One simulated robot: the frame loop (gait -> TDM-PWM -> servos -> MuJoCo), run metrics, a
headless run and the servo load meter (docs/DESIGN.md §2)."""
