"""The house rules of docs/DESIGN.md (§2, §3), read from the source: who may import whom, one joint
order everywhere, short module docstrings, and no citation of a file outside the repository."""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

import mujoco
import pytest

from app.core.robot import RobotModel
from gait import JOINT_NAMES
from hardware import CHANNELS, SERVO_NAMES, ChannelMap

ROOT = Path(__file__).resolve().parent.parent
STDLIB = sys.stdlib_module_names

# package -> the project packages and third-party modules it may import (besides the stdlib)
ALLOWED = {
    "gait": {"gait", "numpy"},
    "hardware": {"hardware", "gait", "numpy"},
    "app.assets": set(),
    "app.core": {
        "app.core",
        "app.assets",
        "app.robots",
        "gait",
        "hardware",
        "numpy",
        "mujoco",
        "serial",
        "distributed",  # app/core/cluster.py, the `cluster` extra
    },
    "app.robots": {
        "app.robots",
        "app.assets",
        "gait",
        "hardware",
        "numpy",
        "mujoco",
        "pydantic",
        "yaml",
    },
    "app.params": {"app.params", "app.assets", "gait", "hardware", "numpy", "pydantic", "yaml"},
}
FORBIDDEN = {  # package -> project packages it must never import
    "app.server": {"app.study", "app.cli"},
    "app.study": {"app.server", "app.cli"},
}


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports_of(path: Path) -> set[str]:
    """Every module imported anywhere in the file (also inside functions and TYPE_CHECKING)."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.add(node.module)
    return found


def owner(module: str, packages: set[str]) -> str | None:
    """The longest of `packages` that `module` is or lies in."""
    hits = [p for p in packages if module == p or module.startswith(p + ".")]
    return max(hits, key=len) if hits else None


SOURCES = sorted(
    p
    for d in ("gait", "hardware", "app")
    for p in (ROOT / d).rglob("*.py")
    if "models" not in p.parts
)


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_imports_run_one_way(path: Path) -> None:
    name = module_name(path)
    package = owner(name, set(ALLOWED) | set(FORBIDDEN))
    if package is None:
        return  # app/__init__.py and app/cli.py may import anything
    for imported in imports_of(path):
        top = imported.split(".")[0]
        if package in ALLOWED:
            if top in STDLIB or top == "__future__":
                continue
            allowed = ALLOWED[package]
            assert owner(imported, allowed) is not None or top in allowed, (
                f"{name} imports {imported}; {package} may import only {sorted(allowed)}"
            )
        else:
            bad = owner(imported, FORBIDDEN[package])
            assert bad is None, f"{name} imports {imported}; {package} never imports {bad}"


def test_the_rule_catches_a_wrong_import(tmp_path: Path) -> None:
    """The reader sees imports inside functions and TYPE_CHECKING blocks too."""
    src = tmp_path / "m.py"
    src.write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    import app.server.x\n")
    assert "app.server.x" in imports_of(src)
    assert owner("app.server.x", FORBIDDEN["app.study"]) == "app.server"


def test_no_code_cites_a_file_outside_the_repository() -> None:
    pattern = re.compile(r"\b(SPEC|STYLE)(\.md|\s*§|\s+rule)")
    cited = [
        f"{p.relative_to(ROOT)}:{n}"
        for p in [
            *SOURCES,
            *(ROOT / "tests").glob("*.py"),
            *(ROOT / "bench").glob("*.py"),
            *(ROOT / "static").rglob("*.js"),
        ]
        for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
        if pattern.search(line) and p.name != "test_layout.py"
    ]
    assert not cited, f"cite docs/DESIGN.md instead: {cited}"


def test_module_docstrings_are_short() -> None:
    """Every module says in 1-5 lines (opening to closing quotes) what it is, which equations it
    implements and where docs/DESIGN.md describes it; the detail lives at the code it explains."""
    missing, long = [], []
    for path in SOURCES:
        tree = ast.parse(path.read_text(encoding="utf-8"))
        if ast.get_docstring(tree, clean=False) is None:
            missing.append(str(path.relative_to(ROOT)))
            continue
        first = tree.body[0]
        assert first.end_lineno is not None
        lines = first.end_lineno - first.lineno + 1
        if lines > 5:
            long.append(f"{path.relative_to(ROOT)} ({lines} lines)")
    assert not missing, f"modules without a docstring: {missing}"
    assert not long, f"module docstrings longer than 5 lines: {long}"


def test_one_joint_order_in_the_gait_the_hardware_the_model_and_the_page() -> None:
    assert SERVO_NAMES is JOINT_NAMES
    model = RobotModel.load().model
    assert [model.actuator(i).name for i in range(model.nu)] == list(JOINT_NAMES)
    hinges = [
        model.joint(i).name
        for i in range(model.njnt)
        if model.joint(i).type == mujoco.mjtJoint.mjJNT_HINGE
    ]
    assert hinges == list(JOINT_NAMES)
    # the default TDM map: one channel per leg for the first five joints, a second for each ankle
    # roll, slots in joint order
    cmap = ChannelMap.default()
    per_channel: dict[str, list[str]] = {}
    for name, (channel, _slot) in zip(JOINT_NAMES, cmap.assignments, strict=True):
        per_channel.setdefault(CHANNELS[channel], []).append(name)
    assert [slot for _c, slot in cmap.assignments[:5]] == [0, 1, 2, 3, 4]
    assert per_channel["OC1A"] == list(JOINT_NAMES[:5])
    # the page's copy (static/js/util.js) lists the same joints in the same order
    util = (ROOT / "static" / "js" / "util.js").read_text(encoding="utf-8")
    joints = re.search(r"export const JOINTS = \[([^\]]*)\]", util)
    assert joints is not None, "static/js/util.js must define JOINTS"
    page = [j.strip().strip('"') for j in joints.group(1).split(",")]
    assert [f"{side}_{j}" for side in "lr" for j in page] == list(JOINT_NAMES)
