"""The server's axle fit: one at a time; the path tracker then predicts with b_eff if it applies."""

from __future__ import annotations

import threading

from app.core.axle_fit import AxleFitResult, fit_effective_axle
from app.server.path_tracker import PathTracker
from gait import GaitParams, Motion


class AxleFitter:
    """One fit at a time for the server; a second request while one runs is refused."""

    def __init__(self) -> None:
        self._busy = threading.Lock()
        self.last: AxleFitResult | None = None
        self.fitted_gait: GaitParams | None = None  # the gait whose b_eff the paths use

    def fit(self, params: GaitParams, motion: Motion, paths: PathTracker) -> AxleFitResult:
        """Fit, and let `paths` predict with b_eff when it applies."""
        if not self._busy.acquire(blocking=False):
            raise RuntimeError("an axle fit is already running; wait for it to finish")
        try:
            self.last = fit_effective_axle(params, motion)
        finally:
            self._busy.release()
        if self.last.applies:
            assert self.last.axle_eff_m is not None
            self.fitted_gait = params
            paths.set_axle(self.last.axle_eff_m, "fitted")
        return self.last

    def stale(self, axle_source: str, gait: GaitParams) -> bool:
        """A fitted axle belongs to the gait it was fitted for: another gait makes it stale."""
        return axle_source == "fitted" and self.fitted_gait not in (None, gait)
