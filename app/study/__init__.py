"""Research tooling: the papers' cases, `artro bench paper`, its report and plots, `artro tune`.

Never imports `app.server` (docs/DESIGN.md §2).
"""
