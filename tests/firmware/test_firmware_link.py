"""The emulated robot behind a pseudo-terminal, reached with pyserial like the real one."""

from __future__ import annotations

import threading

import numpy as np
import serial

from app.firmware import protocol as proto
from app.firmware.link import SerialLink
from app.firmware.protocol import Ack, Info, Msg, Params
from app.firmware.pty_bridge import PtyBridge
from hardware.firmware.schema import param_specs, schema_hash
from tests.testing.firmware_support import emulator, preset


def test_pyserial_talks_to_the_emulated_robot_through_a_pty() -> None:
    stop = threading.Event()
    with emulator(preset("paper")) as mcu:
        bridge = PtyBridge(mcu, realtime=False)
        thread = threading.Thread(target=bridge.serve, args=(stop, 60.0), daemon=True)
        thread.start()
        link = SerialLink(serial.Serial(bridge.port, 57600, timeout=0.02), timeout_s=30.0)
        try:
            (info,) = link.request(proto.command(Msg.PING))
            a_p = next(s.pid for s in param_specs() if s.dotted == "motion.a_p")
            (ack,) = link.request(proto.set_param(a_p, 0.05))
            (params,) = link.request(proto.get_param(a_p))
        finally:
            link.close()
            stop.set()
            thread.join()
            bridge.close()
    assert isinstance(info, Info) and info.schema_hash == schema_hash()
    assert isinstance(ack, Ack) and ack.acked == Msg.SET_PARAM
    assert isinstance(params, Params) and abs(params.values[0] - 0.05) < 1e-7
    assert bridge.bytes_in > 0 and bridge.bytes_out > 0


def test_firmware_drive_frames_equal_the_model_and_follow_a_new_set() -> None:
    from app.firmware.conformance import model_frames
    from app.firmware.pulses import FirmwarePulses
    from app.server.sim.emulated_controller import BUSY_BUDGET_CYCLES

    old, new = preset("paper", a_p=0.07), preset("tuned", a_r=-0.05)
    drive = FirmwarePulses(old)
    try:
        frames = [drive.next_frame() for _ in range(5)]
        effective = drive.set_parameters(new)
        while drive.frame < effective + 5:
            frames.append(drive.next_frame())
    finally:
        drive.close()
    model = model_frames(old, len(frames), changes=[(effective, new)])
    ocr = np.array([f.ocr for f in frames])
    assert np.max(np.abs(ocr - model.ocr)) <= 1 and np.mean(ocr == model.ocr) > 0.99
    assert [f.index for f in frames] == list(range(len(frames)))
    # the set arrives while the link runs the MCU through several frames, whose busy cycles the
    # drive books on the next frame it hands out: judge them over the run (a frame is 320 000)
    busy = [f.busy_cycles for f in frames[1:]]
    assert sum(busy) / len(busy) < BUSY_BUDGET_CYCLES and sum(busy) < 320_000 * len(busy)
