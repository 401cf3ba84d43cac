"""`artro serve`: the FastAPI app, the simulation thread, the parameter store, the scope feed, the
path tracker and the viser view (docs/DESIGN.md §2, §10, §11). Never imports `app.study`.
"""
