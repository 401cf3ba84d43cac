"""Package data (installed as `app.models`): the ArtRo MJCF, its README and the built-in presets."""
