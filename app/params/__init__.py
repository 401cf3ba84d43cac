"""Parameter sets: the document, presets on disk, file formats and the API models of the schema.

Imports `gait` and `hardware` only (docs/DESIGN.md §2).
"""
