"""The ArtRo ATmega128 firmware, built with avr-gcc and run on simavr (docs/DESIGN.md, Firmware).

- `build`: generate the firmware headers for a parameter set and compile (cached); compile the
  simavr harness;
- `emulator`: `Mcu`, the firmware on simavr's ATmega128 core: pin edges, UART, SRAM;
- `protocol`: the host side of the UART protocol (hardware/firmware/PROTOCOL.md);
- `conformance`: emulated edges and angles against the Python model, frame by frame;
- `vcd`: traces as Value Change Dump files;
- `cli`: `artro firmware build|run`.
"""
