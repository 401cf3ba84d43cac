"""`artro link` at its edges (probe B): a dashboard of the wrong shape, a bad --server, --port or
--baud checked before a port is opened, and what PROTOCOL.md says of dropped answers and of
BAD_LENGTH's detail."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from app.firmware import protocol as proto
from app.firmware.emulator import FRAME_CYCLES
from app.firmware.link import EmulatedLink
from app.firmware.protocol import Msg
from app.firmware.robot_link import DEFAULT_BAUD
from tests.testing.firmware_support import emulator, preset
from tests.testing.link_support import (
    artro,
    fake_dashboard,
)

ROOT = Path(__file__).resolve().parents[2]


def _out_of_range() -> bytes:
    doc = preset("tuned") | {"version": 3}
    doc["gait"]["clock"]["freq_hz"] = 99.0
    return json.dumps(doc).encode()


@pytest.mark.parametrize(
    ("body", "content_type", "gave"),
    [
        (
            b"[1, 2]",
            "application/json",
            "GET /api/params gave a JSON list; expected a parameter set",
        ),
        (
            b'{"version": "x", "gait": 5}',
            "application/json",
            "gave a JSON object without motion;",
        ),
        (b"<html>hi</html>", "text/html", "gave text/html, not JSON ('<html>hi</html>');"),
        (
            _out_of_range(),
            "application/json",
            "gave a parameter set this studio cannot take (clock.freq_hz = 99",
        ),
    ],
    ids=["list", "no motion", "html", "out of range"],
)
def test_a_server_that_is_not_a_dashboard_is_named(capsys, body, content_type, gave):
    with fake_dashboard(body, content_type) as url:
        code, out, err = artro(["link", "--dry-run", "--server", url], capsys)
    assert code == 2, err
    assert err.startswith(f"artro link: error: the server at {url} ")
    assert gave in err and "Traceback" not in err + out
    assert "(a JSON object with version, motion and gait)" in err
    assert "TORQUE_OFF" in out  # the servos were switched off all the same


# ---- F7, F14: what is checked before a port is opened, and the port's own words ------------


@pytest.mark.parametrize("server", ["notaurl", "ftp://x", "http://", "http://127.0.0.1:99999"])
def test_a_bad_server_is_refused_before_the_port_is_opened(tmp_path, capsys, server):
    port = tmp_path / "no-such-port"  # opened first, it would be the error
    code, out, err = artro(["link", "--port", str(port), "--server", server], capsys)
    assert code == 2 and out == ""
    assert err.startswith(
        "artro link: error: --server must be a dashboard's address, http://HOST[:PORT] or "
        "https://HOST[:PORT], e.g. http://127.0.0.1:8000;"
    )
    assert repr(server) in err


def test_a_port_that_is_no_serial_device_is_named(tmp_path, capsys):
    regular = tmp_path / "regfile"
    regular.write_text("x")
    folder = tmp_path / "d"
    folder.mkdir()
    missing = tmp_path / "none"
    allowed = "give the robot's serial adapter, e.g. /dev/ttyUSB0, /dev/ttyACM0 or a pty"
    said = {
        regular: f"the port {regular} is not a serial device (a regular file): {allowed}",
        folder: f"the port {folder} is not a serial device (a folder): {allowed}",
        Path("/dev/null"): "the port /dev/null is not a serial device (it takes no line "
        f"settings: Inappropriate ioctl for device): {allowed}",
        missing: f"could not open the port {missing}: No such file or directory",
    }
    for port, message in said.items():
        code, _out, err = artro(["link", "--port", str(port), "--params", "tuned"], capsys)
        assert (code, err) == (2, f"artro link: error: {message}\n")


def test_a_baud_rate_other_than_the_firmwares_is_warned(capsys):
    code, out, _ = artro(["link", "--dry-run", "--baud", "12345", "--params", "tuned"], capsys)
    assert code == 0
    assert out.splitlines()[0] == (
        "warning: --baud 12345: the ArtRo firmware talks at 57600 (hardware/firmware/src/config.h "
        "UART_BAUD); another rate reaches only a firmware built with it"
    )
    code, out, _ = artro(["link", "--dry-run", "--params", "tuned"], capsys)
    assert code == 0 and "warning" not in out


def test_the_default_baud_is_the_firmwares():
    config = (ROOT / "hardware" / "firmware" / "src" / "config.h").read_text(encoding="utf-8")
    (baud,) = re.findall(r"#define UART_BAUD (\d+)UL", config)
    assert int(baud) == DEFAULT_BAUD


# ---- F13, F14: what PROTOCOL.md now says of dropped answers and of BAD_LENGTH's detail ----


def test_a_flood_of_requests_loses_answers_and_the_next_telemetry_says_so():
    with emulator(preset("paper")) as mcu:
        link = EmulatedLink(mcu)
        link.send(proto.command(Msg.PING) * 200)
        replies: list[proto.Reply] = []
        quiet = 0  # frames in a row without a reply, every PING read
        for _ in range(200):  # frames, at most
            got = link.run(FRAME_CYCLES)
            replies += got
            quiet = 0 if got or mcu.uart_queued else quiet + 1
            if quiet == 3:
                break
        answered = sum(isinstance(r, proto.Info) for r in replies)
        assert 0 < answered < 200 and len(replies) == answered  # dropped without a NAK
        (telemetry,) = link.request(proto.command(Msg.GET_TELEMETRY))
        assert telemetry.flags & 0x20
        (telemetry,) = link.request(proto.command(Msg.GET_TELEMETRY))
        assert not telemetry.flags & 0x20  # sticky only until the TELEMETRY that said it


def test_bad_lengths_detail_is_len_at_framing_and_the_payloads_length_after():
    with emulator(preset("paper")) as mcu:
        link = EmulatedLink(mcu)
        (framing,) = link.request(bytes([proto.SYNC, 201]))
        (message,) = link.request(proto.encode(Msg.PING, b"\x00\x00"))
        (a_set,) = link.request(proto.encode(Msg.SET_PARAMS, bytes([0, 2, 0, 0, 0, 0])))
    assert framing == proto.Nak(0, proto.NakReason.BAD_LENGTH, 201)
    assert message == proto.Nak(Msg.PING, proto.NakReason.BAD_LENGTH, 2)
    assert a_set == proto.Nak(Msg.SET_PARAMS, proto.NakReason.BAD_LENGTH, 6)
