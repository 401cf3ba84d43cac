"""ArtRo Gait Studio application: simulation loop, server, viser view and CLI."""
