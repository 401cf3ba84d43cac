"""The wheel carries everything `artro` needs and declares what it imports: installed with its
declared dependencies (at the lock's versions) into a fresh virtual environment that shares nothing
with the test environment, outside the checkout, `artro --help` answers, `artro run` walks the
built-in model and `artro serve` serves the page and the scope."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import tomllib
import venv
import zipfile
from pathlib import Path

import httpx
import pytest

from tests.testing.server_harness import free_port

ROOT = Path(__file__).resolve().parent.parent
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The project's wheel, built from the checkout."""
    tmp = tmp_path_factory.mktemp("wheel")
    built = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp), str(ROOT)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert built.returncode == 0, built.stderr[-2000:]
    (found,) = tmp.glob("artro_gait_studio-*.whl")
    return found


def readme_locked_install() -> list[str]:
    """The README's command for a locked install, `pip install uv==V && uv pip install ...`:
    the uv version it names and the words of its install."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    found = re.search(r"^pip install uv==(\S+) && (uv pip install .*)$", readme, re.MULTILINE)
    assert found, "the README offers a locked install of the package"
    uv_version = (ROOT / "scripts" / "uv-requirement.txt").read_text().strip()
    assert found[1] == uv_version.removeprefix("uv=="), "the README names the uv setup installs"
    return found[2].split()


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> Path:
    """A fresh venv with the project installed by the README's locked-install command, run as
    written in the checkout (the package built from it, its declared runtime dependencies at
    the lock's versions), and no checkout on its path; returns its bin dir."""
    env_dir = tmp_path_factory.mktemp("venv") / "venv"
    venv.create(env_dir, with_pip=False)  # no system site-packages, nothing of this venv's
    uv = shutil.which("uv", path=str(Path(sys.executable).parent)) or shutil.which("uv")
    assert uv, "uv is installed by scripts/setup.sh"
    words = readme_locked_install()
    assert words[:3] == ["uv", "pip", "install"]
    command = [uv, *words[1:3], "--quiet", "--python", str(env_dir / "bin" / "python"), *words[3:]]
    # in a copy of the checkout: a build writes build/ into its source tree, and the `wheel`
    # fixture's build in the checkout itself once collided with it there ("File exists")
    checkout = tmp_path_factory.mktemp("checkout") / "artro"
    junk = (".git", ".venv", "build", "*.egg-info", "__pycache__", ".*_cache", ".hypothesis", "out")
    shutil.copytree(ROOT, checkout, ignore=shutil.ignore_patterns(*junk))
    installed = subprocess.run(command, cwd=checkout, capture_output=True, text=True, timeout=600)
    assert installed.returncode == 0, installed.stderr[-2000:]
    return env_dir / "bin"


def source_packages() -> set[str]:
    """Every Python package of the checkout: a folder of gait/, hardware/ or app/ with an
    __init__.py (models/ and static/ install as app.models and app.static)."""
    return {
        ".".join(init.parent.relative_to(ROOT).parts)
        for top in ("gait", "hardware", "app")
        for init in (ROOT / top).rglob("__init__.py")
    } | {"app.models", "app.static"}


def test_the_wheel_holds_every_package_of_the_source_tree(wheel):
    with zipfile.ZipFile(wheel) as archive:
        names = archive.namelist()
    in_wheel = {str(Path(n).parent).replace("/", ".") for n in names if n.endswith(".py")}
    assert source_packages() - {"app.models", "app.static"} <= in_wheel, (
        f"missing from the wheel (pyproject.toml's packages): "
        f"{sorted(source_packages() - in_wheel)}"
    )
    data = {str(Path(n).parent).replace("/", ".") for n in names}
    assert {"app.models", "app.static", "app.models.robots"} <= data
    assert "app/firmware/harness.c" in names and "hardware/firmware/src/gait.c" in names


def test_the_source_tree_and_pyproject_list_the_same_packages():
    """Fast, without a wheel: pyproject.toml's list is the tree's."""
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
                 ["packages"])  # fmt: skip
    assert listed == source_packages()


def outside_env() -> dict[str, str]:
    """This environment without what would point Python at the checkout or its venv."""
    return {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}


def run_in(tmp: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        args, cwd=tmp, env=outside_env(), capture_output=True, text=True, timeout=300
    )


def test_the_installed_package_is_not_the_checkout(installed, tmp_path):
    out = run_in(
        tmp_path,
        str(installed / "python"),
        "-c",
        "import app.assets as a; print(a.__file__); print(a.builtin_robots_dir()); "
        "print(a.static_dir())",
    )
    assert out.returncode == 0, out.stderr
    for line in out.stdout.split():
        assert str(ROOT) not in line and "site-packages" in line, out.stdout


def test_the_installed_environment_shares_nothing_with_the_tests(installed, tmp_path):
    out = run_in(tmp_path, str(installed / "python"), "-c", "import sys; print(sys.path)")
    assert out.returncode == 0, out.stderr
    ours = sys.prefix  # the test environment (a venv: its own prefix, not the base Python's)
    assert ours not in out.stdout and str(ROOT) not in out.stdout, out.stdout
    assert str(installed.parent) in out.stdout  # its own site-packages


def test_artro_help_from_another_directory(installed, tmp_path):
    out = run_in(tmp_path, str(installed / "artro"), "--help")
    assert out.returncode == 0, out.stderr
    for command in ("serve", "run", "export", "firmware", "link"):
        assert command in out.stdout
    # every subcommand's module imports: the dependencies the wheel declared are there
    for command in ("serve", "run", "export", "link", "tune", "bench"):
        sub = run_in(tmp_path, str(installed / "artro"), command, "--help")
        assert sub.returncode == 0, f"artro {command} --help: {sub.stderr[-2000:]}"


def test_artro_run_from_another_directory(installed, tmp_path):
    out = run_in(
        tmp_path,
        str(installed / "artro"),
        "run",
        "--motion",
        "0,0.07,0",
        "--duration",
        "4",
        "--warmup",
        "1",
        "--json",
    )
    assert out.returncode == 0, out.stderr
    metrics = json.loads(out.stdout)
    assert metrics["fell"] is False and metrics["sim_s"] == pytest.approx(4.0)


def test_artro_serve_from_another_directory(installed, tmp_path):
    port = free_port()
    env = outside_env()
    server = subprocess.Popen(
        [
            str(installed / "artro"),
            "serve",
            "--port",
            str(port),
            "--viser-port",
            str(free_port()),
            "--data-dir",
            str(tmp_path / "data"),
        ],
        cwd=tmp_path,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert server.stdout is not None
        banner = server.stdout.readline()  # printed once the app is built, before it listens
        assert f":{port}" in banner, banner + (server.stderr.read() if server.poll() else "")
        with httpx.Client(base_url=f"http://127.0.0.1:{port}", timeout=10) as http:
            health = _when_up(http, server)
            assert health["status"] == "ok"
            page = http.get("/")
            assert page.status_code == 200 and "<title>" in page.text
            assert http.get("/js/main.js").status_code == 200
            assert http.get("/vendor/uplot/uPlot.iife.min.js").status_code == 200
            assert http.get("/data/safe-bands.json").status_code == 200
            docs = http.get("/docs")
            assert docs.status_code == 200
            assets = re.findall(r'(?:src|href)="(/[^"]+swagger-ui[^"]+)"', docs.text)
            assert len(assets) >= 2, docs.text  # the bundle and its CSS
            for asset in assets:
                assert http.get(asset).status_code == 200, asset  # served from the wheel
            frames = http.get("/api/scope", params={"frames": 1}).json()["frames"]
            assert len(frames) == 1 and len(frames[0]["channels"]) == 6
            presets = {p["name"] for p in http.get("/api/presets").json()["presets"]}
            assert {"paper", "tuned"} <= presets
    finally:
        server.terminate()
        server.wait(30)


def _when_up(http: httpx.Client, server: subprocess.Popen) -> dict:
    """Poll /api/health until the server answers with a frame simulated (bounded tries)."""
    for _ in range(600):
        if server.poll() is not None:
            raise AssertionError(f"artro serve exited: {server.stderr.read()[-2000:]}")
        try:
            health = http.get("/api/health").json()
            if http.get("/api/state").json()["frame"] > 0:
                return health
        except httpx.TransportError:
            pass
        server_wait(server)
    raise AssertionError("artro serve did not come up")


def server_wait(server: subprocess.Popen) -> None:
    """Wait a little for the server without sleeping blind: returns early if it exits."""
    try:
        server.wait(0.1)
    except subprocess.TimeoutExpired:
        pass
