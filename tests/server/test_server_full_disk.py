"""A full disk on a real server (issue 56, item 10): saving a preset answered 500 "(OSError)",
logged a 95-line traceback and reset the connection, so the next request on it failed. Now it is
507 "no space left on the device", one line in the log, and the connection serves on.

The disk is full in one of two ways: a 64 KiB tmpfs filled to the last byte holds the data dir
where a mount is allowed (root), a real full file system; everywhere, a preset store whose
writes go to /dev/full, which the kernel answers with ENOSPC as it answers a full disk."""

from __future__ import annotations

import contextlib
import json
import logging
import socket
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest

from app.params.document import ParameterSet
from app.params.presets import PresetStore, stamped
from tests.testing.server_harness import running_server


class PresetsOnAFullDevice(PresetStore):
    """Presets whose every write meets a full device: the document's bytes go to /dev/full,
    refused by the kernel with ENOSPC, and nothing is stored."""

    def save(self, name: str, pset: ParameterSet) -> ParameterSet:
        self._path(name)  # the name's checks, as a real save makes them
        self._refuse_builtin(name)
        stored = stamped(pset, name)
        self.directory.mkdir(parents=True, exist_ok=True)
        with open("/dev/full", "w", encoding="utf-8") as device:
            device.write(json.dumps(stored.to_dict()))
            device.flush()
        return stored


@contextlib.contextmanager
def full_tmpfs(where: Path) -> Iterator[Path]:
    """A 64 KiB tmpfs at `where`, filled to its last byte; skips the test where it cannot be
    mounted (not root, no mount)."""
    where.mkdir()
    mounted = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(where)], capture_output=True
    )
    if mounted.returncode != 0:
        pytest.skip(f"no tmpfs can be mounted here: {mounted.stderr.decode().strip()}")
    try:
        (where / "presets").mkdir()
        with contextlib.suppress(OSError), open(where / "filler", "wb") as filler:
            while True:
                filler.write(b"\0" * 4096)
                filler.flush()
        yield where
    finally:
        subprocess.run(["umount", str(where)], check=True)


@pytest.fixture(params=["tmpfs", "/dev/full"])
def full_disk_server(request, tmp_path) -> Iterator[tuple[str, Path]]:
    """(base URL, presets folder) of a real server whose presets have no room left."""
    with contextlib.ExitStack() as stack:
        if request.param == "tmpfs":
            data_dir = stack.enter_context(full_tmpfs(tmp_path / "full"))
        else:
            data_dir = tmp_path
        base_url, app = stack.enter_context(running_server(data_dir))
        services = app.state.services
        if request.param == "/dev/full":
            services.presets = PresetsOnAFullDevice(data_dir, services.presets._builtins)
        yield base_url, data_dir / "presets"


def ask(sock: socket.socket, method: str, path: str) -> tuple[int, dict]:
    """Send one request on `sock` (kept open) and read its answer whole: (status, JSON body)."""
    sock.sendall(f"{method} {path} HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n".encode())
    got = b""
    while b"\r\n\r\n" not in got:
        chunk = sock.recv(4096)
        assert chunk, f"the connection was closed before the answer to {method} {path}"
        got += chunk
    head, _, body = got.partition(b"\r\n\r\n")
    lines = head.decode("latin-1").split("\r\n")
    headers = dict(line.lower().split(": ", 1) for line in lines[1:])
    while len(body) < int(headers["content-length"]):
        chunk = sock.recv(4096)
        assert chunk, f"the connection was closed inside the answer to {method} {path}"
        body += chunk
    return int(lines[0].split()[1]), json.loads(body)


def test_a_full_disk_is_said_in_words_the_log_gets_a_line_and_the_connection_serves_on(
    full_disk_server, caplog, capfd
):
    base_url, presets = full_disk_server
    host, port = base_url.removeprefix("http://").split(":")
    with caplog.at_level(logging.WARNING), socket.create_connection((host, int(port)), 30) as sock:
        status, answer = ask(sock, "PUT", "/api/presets/kept")
        assert status == 507, answer
        (item,) = answer["detail"]
        assert item["type"] == "no_space"
        assert item["msg"].startswith(
            "no space left on the device where the server keeps its data: nothing was written"
        )
        status, listed = ask(sock, "GET", "/api/presets")  # the same connection
    assert status == 200
    assert "kept" not in [p["name"] for p in listed["presets"]]
    assert [p.name for p in presets.iterdir()] == []  # no temporary file left either
    said = [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert [r.getMessage().split(" (")[0] for r in said] == [
        "PUT /api/presets/kept: no space left on the device"
    ]
    assert said[0].exc_info is None
    assert "Traceback" not in capfd.readouterr().err
