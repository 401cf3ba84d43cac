"""What the page's live panels read: the scope feed and its frames, a linked robot's sensors
(docs/DESIGN.md §10, §15)."""
