"""The viser 3D view: the view, one class per GUI folder, the ghost drawing, the gate on its port
(docs/DESIGN.md §10)."""
