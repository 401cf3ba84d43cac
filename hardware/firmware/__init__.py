"""ArtRo's ATmega128 firmware: the generated parameter header and (as package data) its C code."""

from hardware.firmware.header import HEADER_NAME, c_float, c_header

__all__ = ["HEADER_NAME", "c_float", "c_header"]
