"""Package data (installed as `app.static`): the dashboard page, served at `/`."""
