"""The emulated UART0 on a pseudo-terminal, so any serial program talks to the emulated robot as
to the real one (docs/DESIGN.md §5): `PtyBridge(mcu).port`, then `serve(stop_event)`; a board
that resets as its port opens (the Mega, docs/BOARDS.md) restarts, its bootloader first."""

from __future__ import annotations

import os
import threading
import time
import tty
from collections.abc import Callable

from app.firmware.emulator import Mcu
from app.firmware.link import SLOT_CYCLES

SLOT_S = 0.0025
#: bytes held for a reader that lags (~11 s of the line at 57600 baud)
PENDING_MAX = 65536


class PtyBridge:
    """Moves bytes between a pty and the emulated UART0 while running the MCU."""

    def __init__(
        self,
        mcu: Mcu,
        *,
        realtime: bool = True,
        restart: Callable[[], Mcu] | None = None,
        bootloader_s: float = 0.0,
    ) -> None:
        """`restart`: the board resets as a program opens the port (an Arduino's DTR): for
        `bootloader_s` of its time the bytes sent go to its bootloader (lost) and nothing
        answers, then `restart()` is the MCU, its firmware booted anew."""
        self.mcu = mcu
        self.realtime = realtime
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # bytes as they are: no echo, no line editing
        os.set_blocking(self._master, False)
        self.port = os.ttyname(self._slave)
        self._restart = restart
        self._boot_slots = round(bootloader_s / SLOT_S)
        self._booting = 0  # slots of the bootloader still to run
        self._opened = False
        self.restarts = 0
        self._slots = 0
        if restart is not None:  # the master reads EIO while no program holds the port open
            os.close(self._slave)
            self._slave = -1
        self.bytes_in = self.bytes_out = 0
        #: what the MCU sent that the pty could not take yet (its buffer full while the reader
        #: lagged): sent first at the next step, as a USB adapter's buffer would hold it
        self._pending = b""

    def step(self) -> None:
        """One TDM slot: host bytes in, 2.5 ms of MCU time, MCU bytes out."""
        opened = True
        try:
            data = os.read(self._master, 4096)
        except BlockingIOError:
            data = b""
        except OSError:  # EIO: no program holds the port open
            data, opened = b"", False
        if self._restart is not None and opened and not self._opened:  # DTR: a reset
            self._booting = self._boot_slots
            self._pending = b""
        self._opened = opened
        if self._restart is not None and self._booting:
            self._booting -= 1  # the bootloader takes the bytes; the firmware is not running
            if not self._booting:
                self.mcu.close()
                self.mcu = self._restart()
                self.restarts += 1
            return
        if data:
            self.mcu.send(data)
            self.bytes_in += len(data)
        self.mcu.run_until(self.mcu.cycle + SLOT_CYCLES)
        _, out = self.mcu.take_uart()
        self._pending = (self._pending + out)[-PENDING_MAX:]  # no reader at all: the newest kept
        if self._pending:
            try:
                sent = os.write(self._master, self._pending)
            except (BlockingIOError, OSError):
                sent = 0
            self._pending = self._pending[sent:]
            self.bytes_out += sent
        self.mcu.take_edges()  # not kept: a long session would pile them up
        self._slots += 1
        if self.mcu.i2c is not None and self._slots % 8 == 0:  # the Mega's bus, once a frame
            self.mcu.i2c.take_edges()
            self.mcu.i2c.take_periods()
            self.mcu.i2c.take_transactions()

    def serve(self, stop: threading.Event, max_seconds: float | None = None) -> None:
        """Run until `stop` is set (or `max_seconds` of MCU time), paced to wall time if
        `realtime` (the emulator may be slower than real time; then it runs flat out)."""
        start = time.monotonic()
        slots = 0
        while not stop.is_set():
            self.step()
            slots += 1
            if max_seconds is not None and slots * SLOT_S >= max_seconds:
                break
            if self.realtime:
                ahead = start + slots * SLOT_S - time.monotonic()
                if ahead > 0:
                    stop.wait(ahead)

    def close(self) -> None:
        if self.restarts:  # an MCU of its own making
            self.mcu.close()
        for fd in (self._master, self._slave):
            if fd < 0:
                continue
            try:
                os.close(fd)
            except OSError:
                pass
