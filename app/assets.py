"""The package data: the ArtRo model, the built-in presets and the dashboard page.

In a checkout they are `models/` and `static/`; installed, the same files are the packages
`app.models` and `app.static` (pyproject.toml maps them). Both are found with importlib.resources,
so `artro` works from a wheel as from the source tree. The files must be on disk (MuJoCo and the
static file server open paths), which every non-zip install gives.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path


def _package_dir(package: str) -> Path:
    found = files(package)
    if not isinstance(found, Path):
        raise RuntimeError(f"{package} is not on disk ({found!r}); install the package unzipped")
    return found


def models_dir() -> Path:
    """The folder with `artro.xml` and `presets/`."""
    return _package_dir("app.models")


def model_xml() -> Path:
    """The built-in ArtRo scene (floor and robot), docs/DESIGN.md "The model"."""
    return models_dir() / "artro.xml"


def builtin_presets_dir() -> Path:
    """The read-only built-in parameter sets (`paper`, `tuned`, ...)."""
    return models_dir() / "presets"


def static_dir() -> Path:
    """The dashboard page served at `/`."""
    return _package_dir("app.static")
