"""Building the firmware (`app.firmware.build`, docs/DESIGN.md §5) with the real avr-gcc: builds
of one set at once share their folder safely, and a failed build says its compiler error first."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest

from app.firmware.build import BuildError, build_firmware
from tests.testing.firmware_support import preset


def test_builds_of_one_set_at_once_all_succeed(tmp_path: Path, monkeypatch) -> None:
    """Twelve builds of one new set, each from its own thread (as concurrent switches of the
    dashboard's drive start them): each rewrote the shared headers while another's make read
    them, and some failed ("'ARTRO_NUM_SERVOS' undeclared")."""
    monkeypatch.setenv("ARTRO_CACHE_DIR", str(tmp_path))
    doc = preset("robust", a_p=0.031)
    builds, errors = [], []

    def build() -> None:
        try:
            builds.append(build_firmware(doc))
        except BuildError as exc:
            errors.append(str(exc))

    threads = [threading.Thread(target=build) for _ in range(12)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == []
    assert len({b.elf for b in builds}) == 1 and builds[0].elf.stat().st_size > 0
    assert not list(tmp_path.rglob(".artro_*"))  # no header part left behind


def test_a_failed_build_says_its_compiler_error_first(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setenv("ARTRO_CACHE_DIR", str(tmp_path))
    with pytest.raises(BuildError) as failed:
        build_firmware(preset("robust"), defines={"ARTRO_BOOT_STATE": "(("})
    first = str(failed.value).splitlines()[0]
    assert first.startswith("make failed: ") and "error" in first, first
