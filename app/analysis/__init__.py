"""What runs mean: the papers' cases (one table), CA analysis and calibration, the axle fit and
robustness; used by the dashboard's jobs and the studies alike (docs/DESIGN.md §2)."""
