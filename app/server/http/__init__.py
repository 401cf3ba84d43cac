"""The HTTP edge of `artro serve`: the app, the request gate, the head deadline, the one error
shape, what a body allows, an upload's checks (docs/DESIGN.md §14)."""
