"""A simulated recording of the identify routine for the fit's tests (about 15 s to make)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

TRUTH = "gyro_bias_deg_s=0.6"  # its hidden variation


def simulated_recording(folder: Path, vary: str = TRUTH) -> Path:
    """`artro run --script identify --record` on artro varied by `vary`: the file's path."""
    path = folder / "rec.json"
    subprocess.run(
        [sys.executable, "-m", "app.cli", "run", "--script", "identify", "--record", str(path),
         "--vary", vary],
        check=True, capture_output=True, text=True,
    )  # fmt: skip
    return path
