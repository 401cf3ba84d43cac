"""`artro serve --board` (docs/BOARDS.md): a board the firmware is not built for, and a board for a
robot of bus servos (no board drives them), exit 2 with a sentence saying why; nothing serves."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from tests.server.test_server_bus_scope import bus_robot
from tests.testing.server_harness import free_port


def serve(tmp_path: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    command = [sys.executable, "-m", "app.cli", "serve", "--no-viewer", "--port", str(free_port())]
    return subprocess.run([*command, "--data-dir", str(tmp_path / "data"), *extra],
                          capture_output=True, text=True, timeout=120)  # fmt: skip


def test_an_unknown_board_is_refused_naming_the_boards(tmp_path: Path) -> None:
    done = serve(tmp_path, "--board", "esp32")
    assert done.returncode == 2
    assert "artro-atmega128" in done.stderr and "mega2560-pca9685" in done.stderr


def test_a_board_for_a_robot_of_bus_servos_is_refused(tmp_path: Path) -> None:
    robot = bus_robot(tmp_path)
    done = serve(tmp_path, "--robot", str(robot), "--board", "mega2560-pca9685")
    assert done.returncode == 2, done.stderr
    assert "--board mega2560-pca9685: the robot 'op3' has bus servos" in done.stderr
    assert "leave --board out" in done.stderr
