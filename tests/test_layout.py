"""The house rules of docs/DESIGN.md (§2, §3), read from the source: the package table of §2 and
every import (who may import whom, no circle anywhere), one joint order everywhere, short module
docstrings, and no citation of a file outside the repository."""

from __future__ import annotations

import ast
import re
import subprocess
import sys
from pathlib import Path

import mujoco
import pytest

from app.robots.model import RobotModel
from gait import JOINT_NAMES
from hardware import CHANNELS, SERVO_NAMES, ChannelMap

ROOT = Path(__file__).resolve().parent.parent
STDLIB = sys.stdlib_module_names
SOURCES = sorted(
    p
    for d in ("gait", "hardware", "app")
    for p in (ROOT / d).rglob("*.py")
    if "models" not in p.parts
)


def layer_table(design: str) -> dict[str, set[str]]:
    """DESIGN §2's table: package -> what it may import (project packages and third-party
    modules), the package itself included."""
    section = design.split("## §2", 1)[1].split("\n## ", 1)[0]
    table: dict[str, set[str]] = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 3 or not cells[0].startswith("`"):
            continue
        package = cells[0].strip("`")
        allowed = {a.strip().strip("`") for a in cells[2].split(",")} - {"—", ""}
        table[package] = allowed | {package}
    return table


ALLOWED = layer_table((ROOT / "docs" / "DESIGN.md").read_text(encoding="utf-8"))


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(p): p for p in SOURCES}


def imports_of(path: Path) -> set[str]:
    """Every module imported anywhere in the file (also inside functions and TYPE_CHECKING),
    relative imports resolved; `from package import name` also names `package.name`."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                package = module_name(path).split(".")[: None if path.name == "__init__.py" else -1]
                up = package[: len(package) - node.level + 1]
                base = ".".join([*up, *([node.module] if node.module else [])])
            found.add(base)
            found.update(f"{base}.{alias.name}" for alias in node.names)
    return {m for m in found if m}


def project_module(imported: str) -> str | None:
    """The module of ours that an import names (its longest prefix that is one), or None."""
    while imported and imported not in MODULES:
        imported = imported.rpartition(".")[0]
    return imported or None


def owner(module: str, packages: set[str]) -> str | None:
    """The longest of `packages` that `module` is or lies in."""
    hits = [p for p in packages if module == p or module.startswith(p + ".")]
    return max(hits, key=len) if hits else None


def test_the_table_lists_every_package_of_app_and_nothing_else() -> None:
    packages = {
        module_name(p.parent / "__init__.py")
        for p in (ROOT / "app").glob("*/__init__.py")
        if p.parent.name not in ("models", "static")
    } | {module_name(p) for p in (ROOT / "app").glob("*.py") if p.name != "__init__.py"}
    assert set(ALLOWED) == packages | {"gait", "hardware"}, (
        "docs/DESIGN.md §2's table and the packages under app/ differ: "
        f"unlisted {sorted(packages - set(ALLOWED))}, "
        f"listed but absent {sorted(set(ALLOWED) - packages - {'gait', 'hardware'})}"
    )


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(ROOT)))
def test_imports_run_one_way(path: Path) -> None:
    name = module_name(path)
    package = owner(name, set(ALLOWED))
    if package is None:
        assert name == "app", f"{name} lies in no package of docs/DESIGN.md §2's table"
        return
    allowed = ALLOWED[package]
    for imported in imports_of(path):
        top = imported.split(".")[0]
        if top in STDLIB or top == "__future__":
            continue
        if top in ("app", "gait", "hardware"):
            ours = project_module(imported)
            if ours is None:
                continue  # `from app.x import name` also lists `app.x.name`
            assert owner(ours, allowed) is not None, (
                f"{name} imports {ours}; {package} may import only {sorted(allowed)}"
            )
        else:
            assert top in allowed, (
                f"{name} imports {top}; {package} may import only {sorted(allowed)}"
            )


def import_graph() -> dict[str, set[str]]:
    """Module -> the modules of ours it imports (a package's own __init__ is not an edge)."""
    graph: dict[str, set[str]] = {}
    for name, path in MODULES.items():
        found = {project_module(i) for i in imports_of(path)}
        graph[name] = {m for m in found if m is not None and m != name}
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_import_circle_anywhere() -> None:
    assert circles(import_graph()) == []


def test_the_rules_catch_a_wrong_import_and_a_circle(tmp_path: Path) -> None:
    """The reader sees imports inside functions and TYPE_CHECKING blocks too, and a circle of
    three modules is found."""
    src = tmp_path / "m.py"
    src.write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    import app.server.x\n")
    assert "app.server.x" in imports_of(src)
    assert owner("app.server.x", ALLOWED["app.study"]) is None
    assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert circles({"a": {"b"}, "b": set()}) == []


def test_no_code_cites_a_file_outside_the_repository() -> None:
    pattern = re.compile(r"\b(SPEC|STYLE)(\.md|\s*§|\s+rule)")
    cited = [
        f"{p.relative_to(ROOT)}:{n}"
        for p in [
            *SOURCES,
            *(ROOT / "tests").rglob("*.py"),
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


#: text files whose references must resolve (history -- the changelog, decision records -- may
#: name what no longer exists)
TEXT_SUFFIXES = {".py", ".js", ".md", ".toml", ".c", ".h", ".sh", ".yaml", ".html", ".css"}
PATH_REF = re.compile(
    r"(?<![\w./-])((?:app|gait|hardware|models|static|tests|bench|docs|scripts|\.ci)/[\w./-]*\w)"
)
MODULE_REF = re.compile(r"`((?:app|gait|hardware)(?:\.[A-Za-z_]\w*)+)[`(]")
PACKAGE_DATA = {"app.models", "app.static"}  # models/ and static/ as installed


def referring_files() -> list[Path]:
    tracked = subprocess.run(
        ["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.split()
    return [
        ROOT / f
        for f in tracked
        if Path(f).suffix in TEXT_SUFFIXES
        and f not in ("CHANGELOG.md", "tests/test_layout.py")  # this file's examples
        and not f.startswith("docs/decisions/")
        and (ROOT / f).exists()
    ]


def module_ref_resolves(dotted: str) -> bool:
    """`app.x.y` names a module of ours, or a name its longest module prefix defines."""
    parts = dotted.split(".")
    for k in range(len(parts), 0, -1):
        base = ROOT.joinpath(*parts[:k])
        source = (
            base.with_suffix(".py") if base.with_suffix(".py").exists() else base / "__init__.py"
        )
        if source.exists():
            return k == len(parts) or re.search(rf"\b{re.escape(parts[k])}\b", source.read_text(
                encoding="utf-8")) is not None  # fmt: skip
    return False


def test_no_comment_or_document_names_a_file_or_module_that_does_not_exist() -> None:
    missing = []
    for path in referring_files():
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            for m in PATH_REF.finditer(line):
                ref = m.group(1).rstrip(".")
                placeholder = any(c in ref for c in "<*{") or re.search(r"[A-Z]{3,}", ref)
                if not placeholder and not (ROOT / ref).exists():
                    missing.append(f"{path.relative_to(ROOT)}:{n}: {ref}")
            for m in MODULE_REF.finditer(line):
                ref = m.group(1)
                file_name = ref.rsplit(".", 1)[-1] in {s[1:] for s in TEXT_SUFFIXES}
                if ref not in PACKAGE_DATA and not file_name and not module_ref_resolves(ref):
                    missing.append(f"{path.relative_to(ROOT)}:{n}: {ref}")
    assert not missing, "names of what does not exist:\n" + "\n".join(missing)
