"""The package data: the built-in robots, the servo table, the presets and the dashboard page.

`models/` and `static/` of a checkout install as `app.models` and `app.static`, found with
importlib.resources, so a wheel works as the source tree does (docs/DESIGN.md §13).
"""

from __future__ import annotations

import os
from importlib import metadata
from importlib.resources import files
from pathlib import Path

STATIC_DIR_ENV = "ARTRO_STATIC_DIR"  # serve the page from this folder instead (development)


def project_version() -> str:
    """The installed artro-gait-studio version, or "unknown" when it is not installed."""
    try:
        return metadata.version("artro-gait-studio")
    except metadata.PackageNotFoundError:
        return "unknown"


def _package_dir(package: str) -> Path:
    """The folder of `package` on disk. MuJoCo and the static file server open paths, which every
    non-zip install gives; RuntimeError otherwise."""
    found = files(package)
    if not isinstance(found, Path):
        raise RuntimeError(f"{package} is not on disk ({found!r}); install the package unzipped")
    return found


def models_dir() -> Path:
    """The folder with `robots/`, `servos.yaml` and `presets/`."""
    return _package_dir("app.models")


def builtin_robots_dir() -> Path:
    """The built-in robot descriptions (`artro.yaml`, ...), described in `models/README.md`."""
    return models_dir() / "robots"


def servo_table_path() -> Path:
    """The servo table: datasheet figures at stated voltages, with their sources."""
    return models_dir() / "servos.yaml"


def builtin_presets_dir() -> Path:
    """The read-only built-in parameter sets (`paper`, `tuned`, ...)."""
    return models_dir() / "presets"


def static_dir() -> Path:
    """The dashboard page served at `/`; `$ARTRO_STATIC_DIR`, when set, overrides it (a page
    being edited in another checkout, served by an installed `artro`)."""
    override = os.environ.get(STATIC_DIR_ENV)
    if override:
        path = Path(override)
        if not (path / "index.html").is_file():
            raise RuntimeError(f"{STATIC_DIR_ENV}={override!r} has no index.html")
        return path
    return _package_dir("app.static")
