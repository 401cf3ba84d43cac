"""The firmware and the gait engines: it runs behnke with the steering term, and refuses pfs."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from app.firmware.build import SOURCE_DIR, build_firmware, generated_headers
from app.firmware.conformance import model_frames, run_comparison
from hardware.firmware import HEADER_NAME
from hardware.firmware.schema import param_specs, values_from_document
from tests.testing.firmware_support import emulator, frames_for_cycles, preset


def test_the_firmware_turns_with_the_steering_term_as_the_model_does() -> None:
    """K = 0.15 at CA = 0.1: eq (29)'s leg yaw a_y + K*CA, in float32, tick for tick."""
    doc = preset("paper", a_p=0.07, ca=0.1)
    doc["gait"]["steer"] = {"yaw_per_ca": 0.15}
    n_frames = frames_for_cycles(doc, 2)
    with emulator(doc) as mcu:
        result = run_comparison(mcu, model_frames(doc, n_frames))
    assert result.mismatches == [], result.mismatches[:5]
    assert result.one_tick <= 0.01 * result.pulses


def test_a_version_1_document_gets_every_id_and_pfs_is_not_among_them() -> None:
    names = [s.dotted for s in param_specs()]
    assert "steer.yaw_per_ca" in names and "ramp.amp_rad_s" in names
    assert not any(n.startswith("pfs.") for n in names)
    values = values_from_document(preset("paper"))  # a v1 file: no steer, no ramp
    assert len(values) == len(names) and values[names.index("steer.yaw_per_ca")] == 0.0


def test_a_pfs_parameter_set_does_not_build(tmp_path: Path) -> None:
    """Refused with a clear message before any compiler runs; and a hand-made pfs header stops
    the C build itself (params.c's #error)."""
    doc = preset("paper")
    doc["gait"]["engine"] = "pfs"
    with pytest.raises(ValueError, match=r"runs the behnke gait engine; .* names 'pfs'"):
        build_firmware(doc)
    headers = generated_headers(preset("paper"))
    headers[HEADER_NAME] = headers[HEADER_NAME].replace(
        "#define ARTRO_ENGINE ARTRO_ENGINE_BEHNKE", "#define ARTRO_ENGINE ARTRO_ENGINE_PFS"
    )
    assert "ARTRO_ENGINE_PFS" in headers[HEADER_NAME].split("#define ARTRO_ENGINE ")[-1]
    for name, text in headers.items():
        (tmp_path / name).write_text(text, encoding="ascii")
    params_c = SOURCE_DIR / "params.c"
    compile_c = ["gcc", "-fsyntax-only", f"-I{tmp_path}", f"-I{SOURCE_DIR}", str(params_c)]
    result = subprocess.run(compile_c, capture_output=True, text=True)
    assert result.returncode != 0 and "does not run" in result.stderr
    headers = generated_headers(preset("paper"))
    for name, text in headers.items():
        (tmp_path / name).write_text(text, encoding="ascii")
    assert subprocess.run(compile_c, capture_output=True).returncode == 0  # behnke compiles
