"""What the tests share and the product does not ship: a live server, the emulated robot, a loopback
Dask cluster, the evaluators' jobs, the browser's checks (docs/EXTENDING.md)."""
