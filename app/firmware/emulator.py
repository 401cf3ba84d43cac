"""The ArtRo firmware on simavr's ATmega128 core, driven from Python through the harness library
(`harness.c`, ctypes): run by cycles or 20 ms frames, pin edges with their CPU cycle, UART bytes,
SRAM by symbol. Frame k starts at t0 + k * FRAME_CYCLES, t0 = when Timer1 started; a timer tick
is 8 cycles (docs/DESIGN.md §5)."""

from __future__ import annotations

import ctypes
import re
import struct
import subprocess
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from app.firmware.build import BOARD_MCU, DEFAULT_BOARD, check_board, harness_library
from app.firmware.i2c import I2cBus, declare_i2c
from app.firmware.sensor_feed import SensorSample
from hardware import CHANNELS, FRAME_TICKS, PRESCALER, SELECT_LINES

LINE_NAMES = CHANNELS + SELECT_LINES  # the order of the harness's line numbers
CYCLES_PER_TICK = PRESCALER
FRAME_CYCLES = FRAME_TICKS * PRESCALER  # 320 000 cycles = 20 ms at 16 MHz
DATA_OFFSET = 0x800000  # avr-gcc puts data-space symbols at 0x800000 + address
CPU_DONE, CPU_CRASHED = 6, 7  # simavr's cpu_Done, cpu_Crashed
_START_TIMEOUT_CYCLES = 16_000_000  # the timers must start within 1 s of reset
PROFILE_BINS = 10  # harness.h: the part marker's values 0..7, in interrupts, asleep
PROFILE_ISR, PROFILE_SLEEP = 8, 9


@dataclass(frozen=True)
class Edges:
    """Level changes on the output lines, oldest first."""

    cycle: NDArray[np.uint64]
    line: NDArray[np.uint8]  # index into LINE_NAMES
    level: NDArray[np.uint8]


class SensorCounts(NamedTuple):
    """The emulated sensors' counters since the start."""

    twi_transactions: int  # begun with the IMU's address (writes at boot included)
    imu_reads: int  # burst reads
    imu_bytes: int
    faults: int  # NACKs and bus errors delivered
    adc_conversions: int


class EmulatorError(RuntimeError):
    """The emulated MCU crashed, stopped, or never started its timers."""


_lib: ctypes.CDLL | None = None


def _library() -> ctypes.CDLL:
    global _lib
    if _lib is None:
        lib = ctypes.CDLL(str(harness_library()))
        p, u64, i64, sz = ctypes.c_void_p, ctypes.c_uint64, ctypes.c_int64, ctypes.c_size_t
        u8p = ctypes.POINTER(ctypes.c_uint8)
        u64p = ctypes.POINTER(ctypes.c_uint64)
        lib.artro_mcu_new.restype = p
        lib.artro_mcu_new.argtypes = [
            ctypes.c_char_p,
            ctypes.c_char_p,
            ctypes.c_int,
            ctypes.c_char_p,
            ctypes.c_int,
        ]
        lib.artro_mcu_free.argtypes = [p]
        lib.artro_mcu_run_until.argtypes = [p, u64]
        lib.artro_mcu_run_until.restype = ctypes.c_int
        lib.artro_mcu_cycle.argtypes = [p]
        lib.artro_mcu_cycle.restype = u64
        lib.artro_mcu_busy_cycles.argtypes = [p]
        lib.artro_mcu_busy_cycles.restype = u64
        lib.artro_mcu_timer_start.argtypes = [p, ctypes.c_int]
        lib.artro_mcu_timer_start.restype = i64
        lib.artro_mcu_take_edges.argtypes = [p, u64p, u8p, u8p, sz]
        lib.artro_mcu_take_edges.restype = sz
        lib.artro_mcu_take_uart.argtypes = [p, u64p, u8p, sz]
        lib.artro_mcu_take_uart.restype = sz
        lib.artro_mcu_uart_send.argtypes = [p, ctypes.c_char_p, sz]
        lib.artro_mcu_uart_send.restype = ctypes.c_int
        lib.artro_mcu_uart_queued.argtypes = [p]
        lib.artro_mcu_uart_queued.restype = sz
        lib.artro_mcu_read.argtypes = [p, ctypes.c_uint32, u8p, ctypes.c_uint32]
        lib.artro_mcu_read.restype = ctypes.c_int
        lib.artro_mcu_attach_sensors.argtypes = [p]
        lib.artro_mcu_attach_sensors.restype = ctypes.c_int
        lib.artro_mcu_set_imu_data.argtypes = [p, ctypes.c_char_p]
        lib.artro_mcu_imu_register.argtypes = [p, ctypes.c_uint8]
        lib.artro_mcu_imu_register.restype = ctypes.c_uint8
        lib.artro_mcu_imu_fault.argtypes = [p, ctypes.c_uint32, ctypes.c_int32]
        lib.artro_mcu_set_adc_mv.argtypes = [p, ctypes.POINTER(ctypes.c_uint16)]
        lib.artro_mcu_sensor_counts.argtypes = [p, ctypes.POINTER(ctypes.c_uint32)]
        lib.artro_mcu_profile.argtypes = [p, ctypes.c_uint32, ctypes.c_uint32]
        lib.artro_mcu_profile_take.argtypes = [p, u64p]
        lib.artro_mcu_profile_take.restype = u64
        lib.artro_mcu_attach_pca9685.argtypes = [p]
        lib.artro_mcu_attach_pca9685.restype = p
        declare_i2c(lib)
        _lib = lib
    return _lib


def elf_symbols(elf: Path) -> dict[str, tuple[int, int]]:
    """{name: (address, size)} of the ELF's data and code symbols (avr-nm)."""
    out = subprocess.run(
        ["avr-nm", "-S", str(elf)], capture_output=True, text=True, check=True
    ).stdout
    symbols = {}
    for addr, size, _kind, name in re.findall(
        r"^([0-9a-f]+) ([0-9a-f]+) (\w) (\S+)$", out, re.MULTILINE
    ):
        symbols[name] = (int(addr, 16), int(size, 16))
    return symbols


class Mcu:
    """One emulated MCU running the ArtRo firmware: ArtRo's ATmega128, or the Mega board's
    ATmega2560 with a PCA9685 on its TWI (`i2c`, docs/BOARDS.md)."""

    def __init__(
        self,
        elf: Path | str,
        *,
        fix_mode14: bool = True,
        fix_ocr_high_byte: bool = True,
        fix_uart_byte_time: bool = True,
        sensors: SensorSample | None = None,
        board: str = DEFAULT_BOARD,
    ) -> None:
        """Load `elf` and run until the firmware has started its timers (frame 0 begins).

        Args:
            sensors: attach the balance sensors (an MPU-6050 on the TWI bus, the force sensors
                on the ADC) holding this sample while the firmware boots and calibrates at
                rest; none: no IMU answers, the ADC reads 0 V.
            fix_mode14: correct simavr's Timer1/Timer3 waveform mode 14 (fast PWM, TOP = ICRn)
                before the firmware runs. False shows the emulator's bug: OCR writes ignored.
            fix_ocr_high_byte: make simavr take a 16-bit OCR write whose low byte is unchanged
                (it drops it). False shows that bug: some pulses off by multiples of 256 ticks.
            fix_uart_byte_time: time a UART byte as the chip does (10 bits at 57600 baud).
                False shows simavr's: U2X0 set after the rate and a parity bit never sent are
                ignored, and the line carries 45 % of its bytes.
            board: the board the ELF was built for (`build_firmware`'s); the Mega's gets its
                PCA9685 and the bus monitor (`self.i2c`) before it boots.
        """
        self.board = check_board(board)
        self.elf = Path(elf)
        self._lib = _library()
        error = ctypes.create_string_buffer(256)
        fixes = (1 if fix_mode14 else 0) | (2 if fix_ocr_high_byte else 0)
        fixes |= 4 if fix_uart_byte_time else 0
        mcu = BOARD_MCU[board].encode()
        handle = self._lib.artro_mcu_new(str(self.elf).encode(), mcu, fixes, error, 256)
        if not handle:
            raise EmulatorError(error.value.decode() or "simavr could not load the firmware")
        self._h: ctypes.c_void_p | None = ctypes.c_void_p(handle)
        self.symbols = elf_symbols(self.elf)
        self.has_sensors = sensors is not None
        self.i2c: I2cBus | None = None
        if board != DEFAULT_BOARD:
            bus = self._lib.artro_mcu_attach_pca9685(self._h)
            if not bus:
                raise EmulatorError(f"simavr's {BOARD_MCU[board]} core has no TWI for the PCA9685")
            self.i2c = I2cBus(self._lib, bus)
        if sensors is not None:
            if self._lib.artro_mcu_attach_sensors(self._h) != 0:
                raise EmulatorError(f"simavr's {BOARD_MCU[board]} core has no TWI for the IMU")
            self.set_sensors(sensors)
        self.t0_cycle = self._wait_for_timers()
        self.timer3_lag_cycles = self._lib.artro_mcu_timer_start(self._h, 3) - self.t0_cycle

    def _wait_for_timers(self) -> int:
        while self._lib.artro_mcu_timer_start(self._h, 3) < 0:
            if self.cycle > _START_TIMEOUT_CYCLES:
                raise EmulatorError("the firmware did not start Timer1/Timer3 within 1 s")
            self._run(self.cycle + 1000)
        return int(self._lib.artro_mcu_timer_start(self._h, 1))

    def set_sensors(self, sample: SensorSample) -> None:
        """What the IMU's data registers hold and the ADC inputs carry from now on."""
        self._lib.artro_mcu_set_imu_data(self._h, sample.imu_registers)
        self._lib.artro_mcu_set_adc_mv(self._h, (ctypes.c_uint16 * 8)(*sample.adc_mv))

    def imu_register(self, reg: int) -> int:
        """A register of the emulated IMU (what the firmware configured)."""
        return int(self._lib.artro_mcu_imu_register(self._h, reg))

    def imu_fault(self, *, nack: int = 0, short_after: int = -1) -> None:
        """Refuse the IMU's next `nack` transactions (no ACK of its address); end its next
        burst with a bus error after `short_after` bytes (-1: not)."""
        self._lib.artro_mcu_imu_fault(self._h, nack, short_after)

    def sensor_counts(self) -> SensorCounts:
        out = (ctypes.c_uint32 * 5)()
        self._lib.artro_mcu_sensor_counts(self._h, out)
        return SensorCounts(*(int(v) for v in out))

    def profile(self, part: str = "g_main_part", flag: str = "g_next_ready") -> None:
        """Count cycles from now on by the value of the SRAM byte `part` (the firmware's
        main-loop part marker, control.h), in interrupts and asleep, and note when the byte
        `flag` rises (the next frame's plan is ready); slower than running plain."""
        addr = {name: self.symbols[name][0] - DATA_OFFSET for name in (part, flag)}
        self._lib.artro_mcu_profile(self._h, addr[part], addr[flag])

    def profile_take(self) -> tuple[NDArray[np.uint64], int]:
        """(cycles per bin since the last take: parts 0..7, in interrupts, asleep; the cycle at
        which the flag last rose)."""
        bins = np.zeros(PROFILE_BINS, dtype=np.uint64)
        rose = self._lib.artro_mcu_profile_take(
            self._h, bins.ctypes.data_as(ctypes.POINTER(ctypes.c_uint64))
        )
        return bins, int(rose)

    def close(self) -> None:
        if getattr(self, "_h", None):
            self._lib.artro_mcu_free(self._h)
            self._h = None

    def __enter__(self) -> Mcu:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __del__(self) -> None:
        self.close()

    # --- running ----------------------------------------------------------------------------

    def _run(self, cycle: int) -> None:
        state = self._lib.artro_mcu_run_until(self._h, cycle)
        if state in (CPU_DONE, CPU_CRASHED):
            raise EmulatorError(f"the emulated MCU stopped (simavr state {state})")

    @property
    def cycle(self) -> int:
        return int(self._lib.artro_mcu_cycle(self._h))

    @property
    def busy_cycles(self) -> int:
        """Cycles the CPU executed (not asleep) since reset."""
        return int(self._lib.artro_mcu_busy_cycles(self._h))

    def frame_start(self, frame: int) -> int:
        return self.t0_cycle + frame * FRAME_CYCLES

    def run_until(self, cycle: int) -> None:
        self._run(cycle)

    def run_to_frame(self, frame: int, tick: int = 0) -> None:
        """Run until `tick` timer ticks into frame `frame`."""
        self._run(self.frame_start(frame) + tick * CYCLES_PER_TICK)

    # --- what came out ----------------------------------------------------------------------

    def take_edges(self) -> Edges:
        parts = []
        while True:
            n = 65536
            cycles = np.empty(n, np.uint64)
            lines = np.empty(n, np.uint8)
            levels = np.empty(n, np.uint8)
            got = self._lib.artro_mcu_take_edges(
                self._h,
                cycles.ctypes.data_as(ctypes.POINTER(ctypes.c_uint64)),
                lines.ctypes.data_as(ctypes.POINTER(ctypes.c_uint8)),
                levels.ctypes.data_as(ctypes.POINTER(ctypes.c_uint8)),
                n,
            )
            parts.append((cycles[:got], lines[:got], levels[:got]))
            if got < n:
                break
        return Edges(*(np.concatenate([p[i] for p in parts]) for i in range(3)))

    def take_uart(self) -> tuple[NDArray[np.uint64], bytes]:
        """(cycle of each byte, the bytes) the firmware sent since the last call."""
        n = 1 << 16
        cycles = np.empty(n, np.uint64)
        data = (ctypes.c_uint8 * n)()
        got = self._lib.artro_mcu_take_uart(
            self._h, cycles.ctypes.data_as(ctypes.POINTER(ctypes.c_uint64)), data, n
        )
        return cycles[:got].copy(), bytes(data[:got])

    # --- what goes in -----------------------------------------------------------------------

    def send(self, data: bytes) -> None:
        """Queue bytes for the firmware's UART0 receiver (fed at its pace, XON/XOFF)."""
        if self._lib.artro_mcu_uart_send(self._h, data, len(data)) != 0:
            raise MemoryError("harness input queue")

    @property
    def uart_queued(self) -> int:
        return int(self._lib.artro_mcu_uart_queued(self._h))

    # --- memory -----------------------------------------------------------------------------

    def read(self, address: int, n: int) -> bytes:
        buf = (ctypes.c_uint8 * n)()
        if self._lib.artro_mcu_read(self._h, address, buf, n) != 0:
            raise ValueError(f"data address {address:#x}+{n} is outside the SRAM")
        return bytes(buf)

    def read_symbol(self, name: str, offset: int = 0, n: int | None = None) -> bytes:
        address, size = self.symbols[name]
        return self.read(address - DATA_OFFSET + offset, size - offset if n is None else n)


# --- the firmware's frame plan (plan.h), read from SRAM -------------------------------------

PLAN_FORMAT = "<IiI12f12H30H16BHBB"  # frame, phase, next phase, angles, servo OCR, table, ...
PLAN_SIZE = struct.calcsize(PLAN_FORMAT)  # 164 bytes


@dataclass(frozen=True)
class PlanDump:
    frame: int
    phase_acc: int
    angles: NDArray[np.float32]  # (12,)
    servo_ocr: NDArray[np.int64]  # (12,)
    saturated: int
    flags: int
    state: int

    @property
    def phase_rad(self) -> float:
        return float(np.float32(self.phase_acc) * np.float32(np.pi / 2**31))


def read_active_plan(mcu: Mcu) -> PlanDump:
    """The plan the TDM interrupt is outputting (g_plan[g_active])."""
    active = mcu.read_symbol("g_active")[0]
    raw = mcu.read_symbol("g_plan", active * PLAN_SIZE, PLAN_SIZE)
    values = struct.unpack(PLAN_FORMAT, raw)
    return PlanDump(
        frame=values[0],
        phase_acc=values[1],
        angles=np.array(values[3:15], np.float32),
        servo_ocr=np.array(values[15:27], np.int64),
        saturated=values[-3],
        flags=values[-2],
        state=values[-1],
    )
