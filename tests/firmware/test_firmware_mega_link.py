"""`artro link --board mega2560-pca9685` against the emulated Mega on a pseudo-terminal
(docs/BOARDS.md): opening the port resets the board and its bootloader answers nothing for 1 s;
the link waits for the firmware's answer to PING before it sends, where a link for a board that
does not reset gets no answer."""

from __future__ import annotations

import re
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

ARTRO = str(Path(sys.executable).with_name("artro"))
MEGA = "mega2560-pca9685"


@pytest.fixture
def mega_on_a_pty() -> Iterator[str]:
    """`artro firmware run --board mega2560-pca9685 --pty`, a process of its own: its port."""
    served = subprocess.Popen(
        [ARTRO, "firmware", "run", "--board", MEGA, "--pty"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        assert served.stdout is not None
        line = served.stdout.readline()
        found = re.search(r"emulated robot on (\S+) \(57600 8N1; it resets as the port opens", line)
        assert found, (line, served.stderr.read() if served.poll() is not None else "")
        yield found[1]
    finally:
        served.send_signal(signal.SIGINT)  # Ctrl-C ends it
        served.communicate(timeout=60)


def link(port: str, *extra: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([ARTRO, "link", "--port", port, "--params", "robust", *extra],
                          capture_output=True, text=True, timeout=120)  # fmt: skip


@pytest.mark.slow
def test_the_link_waits_for_the_megas_restart_before_it_sends(mega_on_a_pty: str) -> None:
    done = link(mega_on_a_pty, "--board", MEGA)
    assert done.returncode == 0, done.stdout + done.stderr
    said = done.stdout
    assert f"waiting for the {MEGA} to restart: opening its port resets it (DTR)" in said
    pings = int(re.search(rf"the {MEGA} answered after (\d+) PINGs", said)[1])  # type: ignore[index]
    assert pings >= 2  # the first went to the bootloader
    frame = int(re.search(r"robot: protocol \d+, \d+ parameters, at frame (\d+)", said)[1])  # type: ignore[index]
    assert frame < 100  # the firmware booted anew as the port opened
    assert re.search(r"sent .*", said), said
    # a link for a board that does not reset asks once, while the bootloader runs
    refused = link(mega_on_a_pty, "--board", "artro-atmega128")
    assert refused.returncode != 0
    assert "ping: no answer from the robot" in refused.stdout + refused.stderr
