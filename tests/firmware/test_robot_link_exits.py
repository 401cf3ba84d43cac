"""`artro link` as a real process (issue 18, item 8): ended by SIGTERM or SIGHUP (a closed
terminal) it switches the servos of the emulated robot off, as Ctrl-C does; a set the firmware
refuses (the pfs engine) is an error, also in a dry run, never "sent"."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest
import serial

from app.firmware import protocol as proto
from app.firmware.link import SerialLink
from tests.testing.firmware_support import preset
from tests.testing.server_harness import running_server, wait_for

ARTRO = Path(sys.executable).with_name("artro")


class Lines:
    """A process's output, line by line, as it comes."""

    def __init__(self, stream) -> None:
        self.lines: list[str] = []
        self._thread = threading.Thread(target=self._read, args=(stream,), daemon=True)
        self._thread.start()

    def _read(self, stream) -> None:
        for line in stream:
            self.lines.append(line.rstrip("\n"))

    def has(self, start: str) -> bool:
        return any(line.startswith(start) for line in self.lines)


def link_process(port: str, server: str) -> subprocess.Popen[str]:
    """`artro link --port PORT --server SERVER` as a process, its output unbuffered."""
    return subprocess.Popen(
        [str(ARTRO), "link", "--port", port, "--server", server],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=os.environ | {"PYTHONUNBUFFERED": "1"},
    )


def _state(port: str) -> proto.RunState:
    link = SerialLink(serial.Serial(port, 57600, timeout=0.02), timeout_s=30.0)
    try:
        (info,) = link.request(proto.encode(proto.Msg.PING))
    finally:
        link.close()
    return info.state


@pytest.mark.slow
@pytest.mark.parametrize("stop", ["SIGTERM", "SIGHUP"])
def test_a_signal_ends_the_link_with_the_servos_off(robot_on_a_pty, tmp_path, stop):
    with running_server(tmp_path) as (base_url, _app):
        link = link_process(robot_on_a_pty, base_url)
        out = Lines(link.stdout)
        try:
            wait_for(lambda: out.has("sent"), "the dashboard's set sent", attempts=1200)
            wait_for(lambda: out.has("following"), "the link following the dashboard")
            link.send_signal(getattr(signal, stop))
            assert link.wait(60) == 0, out.lines
        finally:
            if link.poll() is None:
                link.kill()
    assert any("torque off" in line for line in out.lines), out.lines
    assert _state(robot_on_a_pty) == proto.RunState.TORQUE_OFF


def test_a_pfs_set_is_refused_also_in_a_dry_run(tmp_path):
    pfs = preset("pfs")
    assert pfs["gait"]["engine"] == "pfs"
    (tmp_path / "pfs.json").write_text(json.dumps(pfs))
    run = subprocess.run(
        [str(ARTRO), "link", "--dry-run", "--params", str(tmp_path / "pfs.json")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert run.returncode == 2, run.stdout + run.stderr
    assert "'pfs' gait engine" in run.stderr and "behnke" in run.stderr
    assert "sent" not in run.stdout
    assert "TORQUE_OFF" in run.stdout  # and the servos are switched off all the same
