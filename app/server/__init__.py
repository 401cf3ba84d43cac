"""`artro serve`: the FastAPI app, the simulation thread, the parameter store, the scope feed, the
path tracker and the viser view (docs/DESIGN.md §2, §8, §9). Never imports `app.study`.
"""
