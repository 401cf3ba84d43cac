"""The web oscilloscope's JSON of one TDM-PWM frame: slots, line edges and flags; a bus robot's
sync write; the Mega board's PCA9685 channels and I2C transactions (docs/BOARDS.md)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from app.firmware.mega_pulses import BoardFrame
from app.sim.frame_record import FrameRecord
from hardware import (
    CHANNELS,
    FRAME_TICKS,
    OCR_IDLE,
    SERVO_NAMES,
    SLOT_TICKS,
    TICK_US,
    FrameEdges,
    TdmConfig,
    check_ocr,
    demultiplex,
    falling_edge_ticks,
    frame_edges,
    guard_violations,
)
from hardware.servo_bus import BusLink, bus_frame


def frame_message(
    record: FrameRecord,
    tdm: TdmConfig,
    params_version: int,
    bus: BusLink | None = None,
    board: BoardFrame | None = None,
) -> dict[str, Any]:
    """One scope frame: frame_to_dict plus frame number, time, phase, the version of the
    parameters that produced it, and each slot's angle; for a robot of bus servos, the frame's
    sync write (`bus`: its packet, bytes, time on the wire, the step its goals act at, each
    servo's goal); for the Mega board (`board`), `board`, `pca9685` (each channel's edges) and
    `i2c` (each transaction: address, register, bytes, start and end), `BoardFrame.message`;
    its `channels` and `lines` are then the servos' pulses in the TDM table's layout."""
    data = frame_to_dict(record.ocr, tdm, saturated=record.saturated_servos, edges=record.pin_edges)
    angles = zip(SERVO_NAMES, record.setpoint.tolist(), strict=True)
    degrees = {name: math.degrees(a) for name, a in angles}
    for channel in data["channels"]:
        for slot in channel["slots"]:
            slot["deg"] = degrees.get(slot["servo"])
    return {
        "frame": record.index,
        "t_s": round(record.time_s, 6),
        "phase_rad": record.phase,
        "params_version": params_version,
        "source": "model" if record.pin_edges is None else "firmware",  # who made the pulses
        **data,
        **({"bus": bus_message(record, bus)} if bus is not None else {}),
        **(board.message() if board is not None else {}),
    }


def bus_message(record: FrameRecord, bus: BusLink) -> dict[str, Any]:
    """The frame's sync write of its goals (docs/BUS.md): protocol, baud, the packet (hex), its
    bytes and time on the wire, the frame's physics step its goals act at, each servo's goal."""
    sent = bus_frame(
        record.index, record.setpoint, protocol=bus.protocol, baud=bus.baud, ids=bus.ids
    )
    return {
        "protocol": bus.protocol,
        "baud": bus.baud,
        "packet": sent.packet.hex(" "),
        "bytes": len(sent.packet),
        "wire_us": sent.wire_us,
        "step": sent.substep(),
        "goals": [
            {"servo": name, "id": servo_id, "steps": steps, "deg": math.degrees(rad)}
            for name, servo_id, steps, rad in zip(
                SERVO_NAMES, bus.ids, sent.goal_steps, sent.goal_rad, strict=True
            )
        ],
    }


def frame_to_dict(
    ocr: ArrayLike,
    config: TdmConfig,
    *,
    saturated: ArrayLike | None = None,
    edges: FrameEdges | None = None,
) -> dict[str, Any]:
    """One frame (6, 8) as JSON-ready data for the web oscilloscope.

    Args:
        ocr: OCR values of one frame.
        config: channel map and select timing.
        saturated: optional per-servo flags (12,) from `angles_to_pulses_us`, copied per slot.
        edges: the lines as recorded on pins (the emulated firmware); default: `frame_edges`
            of `ocr`. The demultiplexed pulses are read off these edges.

    Returns:
        {"tick_us", "slot_ticks", "frame_ticks", "select_change_ticks",
         "channels": [{"name", "slots": [{"slot", "servo", "ocr_ticks", "pulse_us", "fall_tick",
                       "decoded_us", "guard_violation", "glitch", "saturated"}]}]  (active slots),
         "lines": [{"name", "initial", "edges": [[tick, level], ...]}]  (see FrameEdges),
         "flags": {"guard_violation": bool, "glitch": [servo names], "saturated": [servo names],
                   "stray": [[channel name, output], ...]}}
        decoded_us is what the demultiplexer measured (null if nothing arrived).
    """
    frame = check_ocr(ocr)
    sat = np.zeros(len(SERVO_NAMES), bool) if saturated is None else np.asarray(saturated, bool)
    if sat.shape != (len(SERVO_NAMES),):
        raise ValueError(f"saturated must have shape ({len(SERVO_NAMES)},), got {sat.shape}")
    if edges is None:
        edges = frame_edges(frame, config)
    decoded = demultiplex(edges, config)
    guard = guard_violations(frame, config)
    falls = falling_edge_ticks(frame, config)
    cmap = config.channel_map

    channels = []
    for channel, name in enumerate(CHANNELS):
        slots = []
        for slot in np.flatnonzero(frame[channel] != OCR_IDLE).tolist():
            servo = cmap.servo_at(channel, slot)
            slot_ocr = int(frame[channel, slot])
            slots.append(
                {
                    "slot": slot,
                    "servo": None if servo is None else SERVO_NAMES[servo],
                    "ocr_ticks": slot_ocr,
                    "pulse_us": (slot_ocr + 1) * TICK_US,
                    "fall_tick": None if servo is None else int(falls[servo]),
                    "decoded_us": None
                    if servo is None or np.isnan(decoded.pulse_us[servo])
                    else float(decoded.pulse_us[servo]),
                    "guard_violation": bool(guard[channel, slot]),
                    "glitch": servo is not None and bool(decoded.glitch[servo]),
                    "saturated": servo is not None and bool(sat[servo]),
                }
            )
        channels.append({"name": name, "slots": slots})

    return {
        "tick_us": TICK_US,
        "slot_ticks": SLOT_TICKS,
        "frame_ticks": FRAME_TICKS,
        "select_change_ticks": config.select_change_ticks,
        "channels": channels,
        "lines": [
            {"name": name, "initial": initial, "edges": [list(edge) for edge in line]}
            for name, initial, line in zip(edges.names, edges.initial, edges.edges, strict=True)
        ],
        "flags": {
            "guard_violation": bool(guard.any()),
            "glitch": [SERVO_NAMES[i] for i in np.flatnonzero(decoded.glitch)],
            "saturated": [SERVO_NAMES[i] for i in np.flatnonzero(sat)],
            "stray": [[CHANNELS[c], output] for c, output in decoded.stray],
        },
    }
