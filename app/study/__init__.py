"""Studies: `artro bench paper` (its runs, report and plots), the `bench robust` report, and
`artro tune` with its loss and study store. Never imports `app.server` (docs/DESIGN.md §2)."""
