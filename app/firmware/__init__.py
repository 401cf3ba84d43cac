"""The ArtRo ATmega128 firmware built with avr-gcc and run on simavr (docs/DESIGN.md §5):
`build` (headers, compile, cache), `emulator` (`Mcu`: pins, UART, SRAM), `protocol` and `link`
(the UART protocol), `conformance` (pins and angles against the Python model), `drive`, `vcd`,
`pty_bridge` and `cli` (`artro firmware build|run`)."""
