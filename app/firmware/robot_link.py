"""A robot's ATmega128 over its serial port: a whole parameter set in one message, the
dashboard's set followed as it changes (polling `GET /api/params`), the servos switched off at
the end; the same code drives the emulated robot on its pty (hardware/firmware/PROTOCOL.md)."""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TextIO

from app.firmware import protocol as proto
from app.firmware.link import SerialLink
from app.params.document import ParameterSet
from hardware.firmware.schema import FIRMWARE_ENGINE, schema_hash, values_from_document

DEFAULT_BAUD = 57600  # PROTOCOL.md: 57600 with U2X at 16 MHz, -0.8 %
POLL_S = 0.2  # how often the dashboard is asked for its parameter version


class LinkError(RuntimeError):
    """The robot did not answer, refused a set, or runs firmware of another schema."""


class DryRunPort:
    """A port that writes each message as hex to a stream and never answers."""

    def __init__(self, out: TextIO) -> None:
        self.out = out

    def write(self, data: bytes) -> int:
        known = len(data) > 2 and data[2] in {m.value for m in proto.Msg}
        name = proto.Msg(data[2]).name if known else "?"
        self.out.write(f"-> {name:13s} {data.hex(' ')}\n")
        return len(data)

    def read(self, size: int = 1) -> bytes:
        return b""

    def close(self) -> None:
        pass


@dataclass
class RobotLink:
    """One robot: `send_set` a whole parameter set, `torque_off` at the end."""

    link: SerialLink
    dry_run: bool = False
    log: Callable[[str], None] = print

    def expect(self, message: bytes, what: str) -> proto.Reply | None:
        replies = self.link.request(message)
        if self.dry_run:
            return None
        if not replies:
            raise LinkError(f"{what}: no answer from the robot (wiring, baud rate, power?)")
        reply = replies[0]
        if isinstance(reply, proto.Nak):
            reason = getattr(reply.reason, "name", reply.reason)
            raise LinkError(f"{what}: the robot refused it ({reason}, detail {reply.detail})")
        return reply

    def hello(self) -> None:
        """PING; the robot's firmware must address parameters as this studio does."""
        info = self.expect(proto.encode(proto.Msg.PING), "ping")
        if info is None:
            return
        if not isinstance(info, proto.Info):
            raise LinkError(f"ping: expected INFO, got {info}")
        if info.schema_hash != schema_hash():
            raise LinkError(
                f"the robot's firmware has schema {info.schema_hash:08x}, this studio "
                f"{schema_hash():08x}: flash the firmware of this version (artro export "
                "--format firmware)"
            )
        self.log(
            f"robot: protocol {info.version}, {info.param_count} parameters, at frame {info.frame}"
        )

    def send_set(self, doc: dict[str, Any], version: int | None = None) -> int | None:
        """The whole set (motion, CA, every constant and the feedback laws) in consecutive
        SET_PARAMS; the frame its last part reaches. LinkError for a set the firmware refuses
        (another gait engine), also in a dry run."""
        engine = doc.get("gait", {}).get("engine", FIRMWARE_ENGINE)
        if engine != FIRMWARE_ENGINE:
            tag = "" if version is None else f" (dashboard version {version})"
            raise LinkError(
                f"the set{tag} names the {engine!r} gait engine; the robot's firmware runs only "
                f"{FIRMWARE_ENGINE!r} and would refuse it: choose engine {FIRMWARE_ENGINE}"
            )
        frame = None
        for message in proto.set_all_params(values_from_document(doc)):
            ack = self.expect(message, "parameter set")
            frame = ack.effective_frame if isinstance(ack, proto.Ack) else None
        where = "" if frame is None else f" from frame {frame}"
        tag = "" if version is None else f" (dashboard version {version})"
        self.log(f"sent {doc.get('name') or 'the parameter set'}{tag}{where}")
        return frame

    def start(self) -> None:
        self.expect(proto.command(proto.Msg.START), "start")

    def torque_off(self) -> None:
        self.expect(proto.command(proto.Msg.TORQUE_OFF), "torque off")
        self.log("torque off")


def follow(
    robot: RobotLink,
    server: str,
    stop: threading.Event,
    *,
    max_updates: int | None = None,
) -> int:
    """Send the dashboard's set, then each new version until `stop` (or `max_updates` sets
    after the first). Returns how many sets were sent."""
    import httpx  # ~0.5 s: only to follow a dashboard

    sent = 0
    last = None
    with httpx.Client(base_url=server, timeout=5) as http:
        while not stop.is_set():
            doc = http.get("/api/params").raise_for_status().json()
            if doc.get("version") != last:
                last = doc.get("version")
                robot.send_set(_plain(doc), last)
                if sent == 0:
                    robot.start()
                sent += 1
                if max_updates is not None and sent > max_updates:
                    break
            stop.wait(POLL_S)
    return sent


def _plain(doc: dict[str, Any]) -> dict[str, Any]:
    """The parameter-set document of an API answer (validated by the schema)."""
    return ParameterSet.from_dict({"motion": doc["motion"], "gait": doc["gait"]}).to_dict() | {
        "name": doc.get("name") or "dashboard"
    }
