"""Dynamixel Protocol 2.0 (CRC-16, byte stuffing) and Feetech STS (checksum) packets, encoded
and decoded, and a parser that tells a byte stream's packets from its noise (docs/BUS.md)."""

from __future__ import annotations

from dataclasses import dataclass, field

# --- Dynamixel Protocol 2.0 -----------------------------------------------------------------

DXL_HEADER = b"\xff\xff\xfd\x00"
BROADCAST_ID = 0xFE
DXL_STATUS = 0x55
PING, READ, WRITE, REG_WRITE, ACTION, REBOOT = 0x01, 0x02, 0x03, 0x04, 0x05, 0x08
SYNC_READ, SYNC_WRITE = 0x82, 0x83
#: the status's error numbers (e-Manual, Protocol 2.0 "Error")
ERR_RESULT_FAIL, ERR_INSTRUCTION, ERR_CRC, ERR_DATA_RANGE = 0x01, 0x02, 0x03, 0x04
ERR_DATA_LENGTH, ERR_DATA_LIMIT, ERR_ACCESS = 0x05, 0x06, 0x07


def _crc_table() -> list[int]:
    table = []
    for i in range(256):
        crc = i << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else crc << 1
        table.append(crc & 0xFFFF)
    return table


_CRC_TABLE = _crc_table()


def crc16(data: bytes) -> int:
    """The CRC-16 of Protocol 2.0 (polynomial 0x8005, initial 0, not reflected, as the
    e-Manual's `update_crc`) over `data`."""
    crc = 0
    for byte in data:
        crc = ((crc << 8) ^ _CRC_TABLE[((crc >> 8) ^ byte) & 0xFF]) & 0xFFFF
    return crc


def stuff(packet_head: bytes, body: bytes) -> bytes:
    """`body` (instruction and parameters) with 0xFD added after every FF FF FD, the pattern
    looked for across the head's last bytes too, as the SDK does."""
    out = bytearray(packet_head[-2:])
    for byte in body:
        out.append(byte)
        if byte == 0xFD and out[-3:-1] == b"\xff\xff":
            out.append(0xFD)
    return bytes(out[2:])


def unstuff(body: bytes, before: bytes = b"") -> bytes:
    """`body` with the stuffing removed: FF FF FD FD becomes FF FF FD."""
    out = bytearray(before[-2:])
    skip = False
    for i, byte in enumerate(body):
        if skip:
            skip = False
            continue
        out.append(byte)
        if byte == 0xFD and out[-3:-1] == b"\xff\xff" and body[i + 1 : i + 2] == b"\xfd":
            skip = True
    return bytes(out[len(before[-2:]) :])


def dxl_packet(servo_id: int, instruction: int, params: bytes = b"") -> bytes:
    """A Protocol 2.0 packet: FF FF FD 00, ID, length (LE, after stuffing), instruction,
    parameters (stuffed), CRC-16 (LE) over everything before it."""
    _check_byte(servo_id, "ID")
    head = DXL_HEADER + bytes([servo_id])
    body = stuff(head + b"\x00\x00", bytes([instruction]) + params)
    head += (len(body) + 2).to_bytes(2, "little")
    crc = crc16(head + body)
    return head + body + crc.to_bytes(2, "little")


def dxl_status(servo_id: int, error: int, params: bytes = b"") -> bytes:
    """A status packet: instruction 0x55, the error byte, then the parameters."""
    return dxl_packet(servo_id, DXL_STATUS, bytes([error]) + params)


def dxl_sync_write(address: int, size: int, values: dict[int, int]) -> bytes:
    """SYNC_WRITE of `size`-byte values (ID -> value, LE) at `address`, to the broadcast ID."""
    params = address.to_bytes(2, "little") + size.to_bytes(2, "little")
    for servo_id, value in values.items():
        params += bytes([servo_id]) + (value & ((1 << 8 * size) - 1)).to_bytes(size, "little")
    return dxl_packet(BROADCAST_ID, SYNC_WRITE, params)


def dxl_sync_read(address: int, size: int, ids: list[int]) -> bytes:
    """SYNC_READ of `size` bytes at `address` from each of `ids`, to the broadcast ID; each
    servo answers in the order of `ids`."""
    params = address.to_bytes(2, "little") + size.to_bytes(2, "little") + bytes(ids)
    return dxl_packet(BROADCAST_ID, SYNC_READ, params)


# --- Feetech STS ----------------------------------------------------------------------------

STS_HEADER = b"\xff\xff"


def sts_checksum(data: bytes) -> int:
    """Feetech's checksum: the low byte of the inverted sum of ID, length, instruction and
    parameters."""
    return ~sum(data) & 0xFF


def sts_packet(servo_id: int, instruction: int, params: bytes = b"") -> bytes:
    """An STS packet: FF FF, ID, length (parameters + 2), instruction, parameters, checksum."""
    _check_byte(servo_id, "ID")
    if len(params) > 250:
        raise ValueError(f"an STS packet carries at most 250 parameter bytes, got {len(params)}")
    body = bytes([servo_id, len(params) + 2, instruction]) + params
    return STS_HEADER + body + bytes([sts_checksum(body)])


def sts_status(servo_id: int, error: int, params: bytes = b"") -> bytes:
    """An STS status: the error byte where the instruction was."""
    return sts_packet(servo_id, error, params)


def sts_sync_write(address: int, size: int, values: dict[int, int]) -> bytes:
    """SYNC_WRITE (0x83) of `size`-byte values (ID -> value, LE) at `address`."""
    params = bytes([address, size])
    for servo_id, value in values.items():
        params += bytes([servo_id]) + (value & ((1 << 8 * size) - 1)).to_bytes(size, "little")
    return sts_packet(BROADCAST_ID, SYNC_WRITE, params)


def sts_sync_read(address: int, size: int, ids: list[int]) -> bytes:
    """SYNC_READ (0x82) of `size` bytes at `address` from each of `ids`, in their order."""
    return sts_packet(BROADCAST_ID, SYNC_READ, bytes([address, size, *ids]))


def _check_byte(value: int, what: str) -> None:
    if not 0 <= value <= 0xFF:
        raise ValueError(f"{what} must be 0..255, got {value}")


# --- parsing a byte stream ------------------------------------------------------------------

PROTOCOLS = ("dynamixel", "feetech")
MAX_LENGTH = 1024  # a longer length field is taken for noise


@dataclass(frozen=True)
class Packet:
    """A whole packet off the wire: for a status, `instruction` is 0x55 (Dynamixel) or the error
    byte (Feetech); `params` unstuffed."""

    servo_id: int
    instruction: int
    params: bytes
    size: int  # bytes on the wire


@dataclass(frozen=True)
class Malformed:
    """Bytes that were no packet: `servo_id` when the header and ID were whole (a servo of that
    ID hears it), None for noise; `reason` one of "noise", "length", "crc", "checksum"."""

    servo_id: int | None
    reason: str
    size: int


@dataclass
class Parser:
    """Splits a byte stream into packets of one protocol; `feed` returns what it completed."""

    protocol: str
    buffer: bytearray = field(default_factory=bytearray)

    def __post_init__(self) -> None:
        if self.protocol not in PROTOCOLS:
            raise ValueError(f"protocol must be one of {PROTOCOLS}, got {self.protocol!r}")

    def feed(self, data: bytes) -> list[Packet | Malformed]:
        self.buffer += data
        found: list[Packet | Malformed] = []
        while True:
            item = self._next()
            if item is None:
                return found
            found.append(item)

    def drop(self) -> Malformed | None:
        """Forget a partial packet (the line fell quiet in the middle of one)."""
        if not self.buffer:
            return None
        size, self.buffer = len(self.buffer), bytearray()
        return Malformed(None, "partial", size)

    def _skip_to_header(self, header: bytes) -> Malformed | None:
        at = self.buffer.find(header)
        keep = len(self.buffer) - len(header) + 1 if at < 0 else at
        keep = max(keep, 0)
        if at < 0:  # a header's start may sit at the end: keep what could begin one
            while keep < len(self.buffer) and not header.startswith(bytes(self.buffer[keep:])):
                keep += 1
        if keep == 0:
            return None
        del self.buffer[:keep]
        return Malformed(None, "noise", keep)

    def _next(self) -> Packet | Malformed | None:
        if self.protocol == "dynamixel":
            return self._next_dxl()
        return self._next_sts()

    def _next_dxl(self) -> Packet | Malformed | None:
        noise = self._skip_to_header(DXL_HEADER)
        if noise is not None:
            return noise
        buf = self.buffer
        if len(buf) < 7:
            return None
        servo_id, length = buf[4], int.from_bytes(buf[5:7], "little")
        if length < 3 or length > MAX_LENGTH or servo_id == 0xFF:
            del buf[:1]  # no packet starts here: look for the next header
            return Malformed(None, "length", 1)
        total = 7 + length
        if len(buf) < total:
            return None
        raw = bytes(buf[:total])
        del buf[:total]
        if crc16(raw[:-2]) != int.from_bytes(raw[-2:], "little"):
            return Malformed(servo_id, "crc", total)
        body = unstuff(raw[7:-2], raw[5:7])
        return Packet(servo_id, body[0], body[1:], total)

    def _next_sts(self) -> Packet | Malformed | None:
        noise = self._skip_to_header(STS_HEADER)
        if noise is not None:
            return noise
        buf = self.buffer
        if len(buf) >= 3 and buf[2] == 0xFF:  # FF FF FF: the header is one byte later
            del buf[:1]
            return Malformed(None, "noise", 1)
        if len(buf) < 4:
            return None
        servo_id, length = buf[2], buf[3]
        if length < 2:
            del buf[:1]
            return Malformed(None, "length", 1)
        total = 4 + length
        if len(buf) < total:
            return None
        raw = bytes(buf[:total])
        del buf[:total]
        if sts_checksum(raw[2:-1]) != raw[-1]:
            return Malformed(servo_id, "checksum", total)
        return Packet(servo_id, raw[4], raw[5:-1], total)
