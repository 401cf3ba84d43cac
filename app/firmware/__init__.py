"""The ArtRo ATmega128 firmware (its C sources: `hardware/firmware/`) built with avr-gcc, run on
simavr and checked pin for pin against the Python model (docs/DESIGN.md §5): `build`, `emulator`
(`Mcu`), `conformance`, `pulses` (the emulated firmware as the simulation's pulse source),
`protocol` and `link` (the UART protocol), `robot_link` (a real robot), `pty_bridge`, `vcd`."""
