"""Parameter sets: the document, presets on disk, file formats and the API models of the schema
(docs/DESIGN.md §6)."""
