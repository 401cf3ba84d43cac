"""The package declares what it imports, and the environment is the lock (docs/DESIGN.md §13):
every third-party module that `app/`, `gait/` and `hardware/` import belongs to a runtime
dependency of pyproject.toml; every declared dependency is pinned in requirements.lock at a
version its range admits; and this environment holds exactly the pinned versions."""

from __future__ import annotations

import ast
import re
import sys
import tomllib
from importlib import metadata
from pathlib import Path

import pytest
from packaging.markers import Marker
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

from tests.test_layout import SOURCES, imports_of

ROOT = Path(__file__).resolve().parent.parent
PROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
OWN = {"app", "gait", "hardware", "models"}


def runtime_requirements() -> list[Requirement]:
    return [Requirement(r) for r in PROJECT["dependencies"]]


def all_requirements() -> list[Requirement]:
    extras = PROJECT.get("optional-dependencies", {})
    return runtime_requirements() + [Requirement(r) for rs in extras.values() for r in rs]


def lock_pins() -> list[tuple[str, str, Marker | None]]:
    """(name, version, marker) of every pin in requirements.lock."""
    pins = []
    pin = re.compile(r"^([A-Za-z0-9._-]+)==([^\s;\\]+)\s*(?:;\s*([^\\]+?))?\s*\\?$")
    for line in (ROOT / "requirements.lock").read_text(encoding="utf-8").splitlines():
        if m := pin.match(line):
            marker = Marker(m[3]) if m[3] else None
            pins.append((canonicalize_name(m[1]), m[2], marker))
    return pins


def pins_here() -> dict[str, str]:
    """The pins whose markers hold in this interpreter."""
    return {n: v for n, v, mk in lock_pins() if mk is None or mk.evaluate()}


def third_party_modules() -> dict[str, set[str]]:
    """Top-level third-party module -> the source files importing it."""
    found: dict[str, set[str]] = {}
    for path in SOURCES:
        for module in imports_of(path):
            top = module.split(".")[0]
            if top in sys.stdlib_module_names or top in OWN or top == "__future__":
                continue
            found.setdefault(top, set()).add(str(path.relative_to(ROOT)))
    return found


def top_level_imports(path: Path) -> set[str]:
    """The modules a file imports when it is imported: not those inside functions."""
    found: set[str] = set()
    tree = ast.parse(path.read_text(encoding="utf-8"))
    nested = {
        id(inner)
        for node in ast.walk(tree)
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
        for inner in ast.walk(node)
    }
    for node in ast.walk(tree):
        if id(node) in nested:
            continue
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.add(node.module)
    return found


def test_every_imported_module_is_a_declared_dependency() -> None:
    """Runtime dependencies cover every import, but those made inside a function for an
    optional extra's feature (Dask for `--cluster`), which the extra must declare."""
    runtime = {canonicalize_name(r.name) for r in runtime_requirements()}
    extras = {
        canonicalize_name(Requirement(r).name)
        for rs in PROJECT.get("optional-dependencies", {}).values()
        for r in rs
    }
    eager = {m.split(".")[0] for path in SOURCES for m in top_level_imports(path)}
    providers = metadata.packages_distributions()
    missing = {}
    for module, files in sorted(third_party_modules().items()):
        dists = {canonicalize_name(d) for d in providers.get(module, [])}
        assert dists, f"{module} (imported by {sorted(files)}) is not installed here"
        allowed = runtime if module in eager else runtime | extras
        if not dists & allowed:
            missing[module] = (sorted(dists), sorted(files))
    assert not missing, f"imported but not declared in pyproject.toml: {missing}"


def test_the_import_scan_sees_the_imports_that_matter() -> None:
    """The scan is not vacuous: it finds the libraries the studio is built on."""
    assert {"numpy", "mujoco", "fastapi", "viser", "httpx", "yaml"} <= set(third_party_modules())


def test_every_declared_dependency_is_locked_within_its_range() -> None:
    locked = {}
    for name, version, _ in lock_pins():
        locked.setdefault(name, []).append(version)
    for req in all_requirements():
        versions = locked.get(canonicalize_name(req.name))
        assert versions, f"{req.name} is declared but not locked: run `bash scripts/lock.sh`"
        for version in versions:
            assert req.specifier.contains(version, prereleases=True), (
                f"the lock pins {req.name}=={version}, outside {req}: run `bash scripts/lock.sh`"
            )


def test_the_lock_names_no_index_host_or_machine_path() -> None:
    text = (ROOT / "requirements.lock").read_text(encoding="utf-8")
    assert not re.search(r"--(extra-)?index-url|--find-links|https?://|file:|/home/|/root/", text)


@pytest.mark.parametrize("name", ["mujoco", "numpy", "fastapi", "viser", "pydantic", "optuna"])
def test_the_figures_libraries_are_pinned(name: str) -> None:
    assert name in pins_here()


def test_this_environment_holds_exactly_the_locked_versions() -> None:
    """What scripts/setup.sh installed is the lock, not whatever the index holds today."""
    wrong = {}
    for name, version in pins_here().items():
        try:
            have = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue  # a pin of an extra this environment did not ask for
        if have != version:
            wrong[name] = f"{have} installed, {version} locked"
    assert not wrong, f"run `bash scripts/setup.sh --test`: {wrong}"
    assert metadata.version("mujoco") == pins_here()["mujoco"]  # the figures' engine is there
