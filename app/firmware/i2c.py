"""The emulated Mega board's I2C bus (docs/BOARDS.md): the PCA9685 part's output edges and
periods, and each transaction the TWI made (harness_i2c.c), with its time on a 400 kHz bus:
9 clocks a byte (8 bits and the ACK) and one each for START, every repeated START and STOP."""

from __future__ import annotations

import ctypes
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

PCA_CHANNELS = 16
PCA9685_ADDRESS, IMU_ADDRESS = 0x40, 0x68
BUS_HZ = 400_000
OSC_HZ = 25_000_000
F_CPU_HZ = 16_000_000
FULL = 0x1000  # bit 12 of an ON or OFF value: full ON / full OFF


def declare_i2c(lib: ctypes.CDLL) -> None:
    """The argument types of harness_i2c.c's calls."""
    p, sz = ctypes.c_void_p, ctypes.c_size_t
    u8p, u16p = ctypes.POINTER(ctypes.c_uint8), ctypes.POINTER(ctypes.c_uint16)
    u64p = ctypes.POINTER(ctypes.c_uint64)
    lib.artro_pca_register.argtypes = [p, ctypes.c_uint8]
    lib.artro_pca_register.restype = ctypes.c_uint8
    lib.artro_pca_take_edges.argtypes = [p, u64p, u8p, u8p, sz]
    lib.artro_pca_take_edges.restype = sz
    lib.artro_pca_take_periods.argtypes = [p, u64p, u8p, u16p, u16p, sz]
    lib.artro_pca_take_periods.restype = sz
    lib.artro_i2c_take.argtypes = [p, u64p, u64p, u8p, u8p, u16p, u8p, u8p, sz]
    lib.artro_i2c_take.restype = sz


def _ptr(array: NDArray, kind: type) -> ctypes._Pointer:
    return array.ctypes.data_as(ctypes.POINTER(kind))


@dataclass(frozen=True)
class PcaPeriods:
    """The PCA9685's counter periods begun: start cycle, PRESCALE, each channel's ON and OFF."""

    start_cycle: NDArray[np.uint64]
    prescale: NDArray[np.uint8]
    on: NDArray[np.uint16]  # (n, 16)
    off: NDArray[np.uint16]  # (n, 16)

    def step_s(self) -> NDArray[np.float64]:
        return (self.prescale.astype(np.float64) + 1.0) / OSC_HZ

    def pulse_s(self) -> NDArray[np.float64]:
        """(n, 16) each channel's high time in the period (ON = 0 pulses; full OFF: 0)."""
        on, off = self.on & 0x0FFF, self.off & 0x0FFF
        steps = (off.astype(np.int64) - on.astype(np.int64)) % 4096
        steps = np.where(self.off & FULL, 0, np.where(self.on & FULL, 4096, steps))
        return steps * self.step_s()[:, None]


@dataclass(frozen=True)
class Transactions:
    """I2C transactions, START to STOP, oldest first."""

    start_cycle: NDArray[np.uint64]
    stop_cycle: NDArray[np.uint64]
    address: NDArray[np.uint8]  # 7-bit
    write: NDArray[np.bool_]  # its first address byte was SLA+W
    register: NDArray[np.int16]  # the first register written, -1: none
    bytes: NDArray[np.uint16]  # on the wire, address bytes included
    restarts: NDArray[np.uint8]
    acked: NDArray[np.bool_]  # a part acknowledged its address

    def __len__(self) -> int:
        return len(self.start_cycle)

    def bus_s(self) -> NDArray[np.float64]:
        """Each one's time on a 400 kHz bus: (9 bytes + START + restarts + STOP) clocks."""
        clocks = 9 * self.bytes.astype(np.int64) + 2 + self.restarts.astype(np.int64)
        return clocks / BUS_HZ

    def select(self, keep: NDArray[np.bool_]) -> Transactions:
        return Transactions(*(getattr(self, f)[keep] for f in self.__dataclass_fields__))


class I2cBus:
    """The harness's bus: the PCA9685 at 0x40 and the monitor."""

    def __init__(self, lib: ctypes.CDLL, handle: int) -> None:
        self._lib, self._bus = lib, ctypes.c_void_p(handle)

    def register(self, reg: int) -> int:
        """A register of the PCA9685 as the firmware wrote it."""
        return int(self._lib.artro_pca_register(self._bus, reg))

    def take_edges(self) -> tuple[NDArray[np.uint64], NDArray[np.uint8], NDArray[np.uint8]]:
        """(cycle, channel, level) of the PCA9685's output edges recorded since the last call
        (a period's are recorded at its start), oldest first."""
        n = 1 << 16
        parts = []
        while True:
            cycles, lines, levels = (
                np.empty(n, np.uint64),
                np.empty(n, np.uint8),
                np.empty(n, np.uint8),
            )
            got = self._lib.artro_pca_take_edges(
                self._bus, _ptr(cycles, ctypes.c_uint64), _ptr(lines, ctypes.c_uint8),
                _ptr(levels, ctypes.c_uint8), n,
            )  # fmt: skip
            parts.append((cycles[:got], lines[:got], levels[:got]))
            if got < n:
                break
        cycles, lines, levels = (np.concatenate([part[i] for part in parts]) for i in range(3))
        return cycles, lines, levels

    def take_periods(self) -> PcaPeriods:
        n = 4096
        starts, prescale = np.empty(n, np.uint64), np.empty(n, np.uint8)
        on, off = np.empty((n, PCA_CHANNELS), np.uint16), np.empty((n, PCA_CHANNELS), np.uint16)
        got = self._lib.artro_pca_take_periods(
            self._bus, _ptr(starts, ctypes.c_uint64), _ptr(prescale, ctypes.c_uint8),
            _ptr(on, ctypes.c_uint16), _ptr(off, ctypes.c_uint16), n,
        )  # fmt: skip
        return PcaPeriods(
            starts[:got].copy(), prescale[:got].copy(), on[:got].copy(), off[:got].copy()
        )

    def take_transactions(self) -> Transactions:
        n = 4096
        start, stop = np.empty(n, np.uint64), np.empty(n, np.uint64)
        address, reg, restarts, acked = (np.empty(n, np.uint8) for _ in range(4))
        nbytes = np.empty(n, np.uint16)
        got = self._lib.artro_i2c_take(
            self._bus, _ptr(start, ctypes.c_uint64), _ptr(stop, ctypes.c_uint64),
            _ptr(address, ctypes.c_uint8), _ptr(reg, ctypes.c_uint8), _ptr(nbytes, ctypes.c_uint16),
            _ptr(restarts, ctypes.c_uint8), _ptr(acked, ctypes.c_uint8), n,
        )  # fmt: skip
        address = address[:got]
        seven_bit = (address >> 1).astype(np.uint8, copy=False)  # uint8 as it was: the stubs widen
        return Transactions(
            start[:got].copy(), stop[:got].copy(), seven_bit, (address & 1) == 0,
            np.where(reg[:got] == 0xFF, -1, reg[:got]).astype(np.int16), nbytes[:got].copy(),
            restarts[:got].copy(), acked[:got] != 0,
        )  # fmt: skip
