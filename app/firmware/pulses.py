"""The emulated firmware as the simulation's pulse source, one 20 ms frame per call: OCR decoded
from the pins, the edges, the firmware's angles and phase; parameter sets go over the emulated
UART (docs/DESIGN.md §5); the simulated sensors reach it through its emulated IMU and ADC
(`feed`, docs/DESIGN.md §15)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from app.firmware import protocol as proto
from app.firmware.build import DEFAULT_BOARD, build_firmware
from app.firmware.conformance import frame_edges_of
from app.firmware.emulator import Edges, Mcu, read_active_plan
from app.firmware.link import EmulatedLink
from app.firmware.sensor_feed import RawSample, at_rest, raw_of, sample_of
from app.sim.sensors import SensorReading
from gait import ARTRO_LEG, LegGeometry
from hardware import (
    CHANNELS,
    OCR_IDLE,
    SERVO_NAMES,
    SLOT_TICKS,
    SLOTS_PER_FRAME,
    FrameEdges,
    ServoCalibration,
    TdmConfig,
)
from hardware.firmware.schema import values_from_document


@dataclass(frozen=True)
class FirmwareFrame:
    index: int
    phase_rad: float  # the firmware's phi_Trunk (float32)
    angles_rad: NDArray[np.float32]  # (12,) the firmware's joint angles
    ocr: NDArray[np.int32]  # (6, 8) decoded from the pins; -1 = idle
    edges: FrameEdges  # the nine lines as recorded, ticks from the frame start
    busy_cycles: int  # CPU cycles not asleep during the frame
    saturated: NDArray[np.bool_]  # (12,) the firmware clipped this servo's angle or pulse
    gamma_clamped: bool  # eq (45) summed below -1 on some leg
    replies: tuple[proto.Reply, ...] = ()  # what the firmware answered during the frame


def ocr_from_edges(edges: FrameEdges) -> NDArray[np.int32]:
    """(6, 8) OCR values of the pulses on the TDM lines: high time - 1 per slot, -1 if none."""
    ocr = np.full((len(CHANNELS), SLOTS_PER_FRAME), OCR_IDLE, np.int32)
    for c, name in enumerate(CHANNELS):
        initial, line = edges.line(name)
        rise = 0 if initial else None
        for tick, level in line:
            if level:
                rise = tick
            elif rise is not None:
                slot = rise // SLOT_TICKS
                ocr[c, slot] = tick - rise - 1
                rise = None
    return ocr


PLAN_GAMMA_CLAMPED = 0x02  # plan.h's PLAN_GAMMA_CLAMPED
_PLAN_TICK = 100  # the frame's plan is latched at its start: read it just after


def _concat(a: Edges, b: Edges) -> Edges:
    return Edges(
        *(
            np.concatenate([x, y])
            for x, y in zip((a.cycle, a.line, a.level), (b.cycle, b.line, b.level), strict=True)
        )
    )


def _since(edges: Edges, cycle: int) -> Edges:
    keep = edges.cycle >= cycle
    return Edges(edges.cycle[keep], edges.line[keep], edges.level[keep])


class FirmwarePulses:
    """One emulated robot controller, advanced frame by frame."""

    def __init__(
        self,
        doc: dict[str, Any],
        *,
        calibration: ServoCalibration | None = None,
        tdm: TdmConfig | None = None,
        geometry: LegGeometry = ARTRO_LEG,
        fsr_positions_m: Any = None,
        sensors: bool = True,
        board: str = DEFAULT_BOARD,
    ) -> None:
        """Build the firmware with `doc` as its defaults (cached) for a robot's wiring, legs and
        sole sensors and boot it, with its IMU and force sensors attached (`sensors`; held at
        rest while it calibrates); BuildError, ValueError (an engine it does not run) or
        EmulatorError if that fails. `board`: the board built and emulated (docs/BOARDS.md;
        the Mega's frames: `app.firmware.mega_pulses.MegaPulses`)."""
        extra = {} if fsr_positions_m is None else {"fsr_positions_m": fsr_positions_m}
        if board != DEFAULT_BOARD:
            extra["board"] = board
        self.build = build_firmware(
            doc, calibration=calibration, tdm=tdm, geometry=geometry, **extra
        )
        self.raw: RawSample = at_rest()  # what the sensors show the firmware from now on
        self.mcu = Mcu(
            self.build.elf, sensors=sample_of(self.raw) if sensors else None, board=board
        )
        self.link = EmulatedLink(self.mcu)
        self.frame = 0
        self._busy = self.mcu.busy_cycles
        self._recent: Edges | None = None  # edges of the last two frames: levels carry over

    def next_frame(self) -> FirmwareFrame:
        k = self.frame
        self.mcu.run_to_frame(k, _PLAN_TICK)
        plan = read_active_plan(self.mcu)
        self.mcu.run_to_frame(k + 1, _PLAN_TICK)  # past the edges at the next frame's start
        replies = tuple(r for r in self.link.poll() if not isinstance(r, proto.Telemetry))
        new = self.mcu.take_edges()
        recent = new if self._recent is None else _concat(self._recent, new)
        keep_from = self.mcu.frame_start(max(k - 1, 0))
        self._recent = _since(recent, keep_from)
        edges = frame_edges_of(recent, self.mcu.t0_cycle, k)
        busy = self.mcu.busy_cycles
        frame = FirmwareFrame(
            k,
            plan.phase_rad,
            plan.angles,
            ocr_from_edges(edges),
            edges,
            busy - self._busy,
            saturated=(plan.saturated >> np.arange(len(SERVO_NAMES))) & 1 == 1,
            gamma_clamped=bool(plan.flags & PLAN_GAMMA_CLAMPED),
            replies=replies,
        )
        self._busy = busy
        self.frame += 1
        return frame

    def feed(self, reading: SensorReading) -> RawSample:
        """What the simulated sensors read: the IMU's registers and the ADC's inputs hold it
        from now on (the firmware samples them in the next frame's slot 3); the counts."""
        return self.show(raw_of(reading))

    def show(self, raw: RawSample) -> RawSample:
        """The counts the sensors show the firmware from now on."""
        self.raw = raw
        self.mcu.set_sensors(sample_of(raw))
        return raw

    def send_parameters(self, doc: dict[str, Any]) -> int:
        """Queue a whole parameter set on the UART and go on: the bytes go in at the line's pace
        while frames run, and an ACK (the last names the first frame the set reaches) or NAK
        per message comes back in later frames' `replies`. Returns how many messages."""
        messages = proto.set_all_params(values_from_document(doc))
        for message in messages:
            self.link.send(message)
        return len(messages)

    def set_parameters(self, doc: dict[str, Any]) -> int:
        """Send a whole parameter set and run until it is answered; returns the first frame it
        reaches (from the ACK)."""
        frame = 0
        for message in proto.set_all_params(values_from_document(doc)):
            (reply,) = self.link.request(message)
            if not isinstance(reply, proto.Ack):
                raise ValueError(f"the firmware rejected the parameter set: {reply}")
            frame = reply.effective_frame
        return frame

    def close(self) -> None:
        self.mcu.close()
