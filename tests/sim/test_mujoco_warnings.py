"""MuJoCo's warnings stay out of the working folder (`app.robots.mujoco_warnings`): a blow-up in
`artro`'s process or a worker's writes no MUJOCO_LOG.TXT where the command runs."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import mujoco

from app.cli import main
from app.robots.mujoco_warnings import log_warning

BLOW_UP = textwrap.dedent(
    """
    import logging, os, sys
    import mujoco
    import numpy as np
    from mujoco import rollout
    {install}
    logging.basicConfig(level=logging.INFO, format="%(name)s: %(message)s")
    m = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body><freejoint/><geom size="0.1"/></body></worldbody></mujoco>')
    state = np.zeros((4, mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS)))
    d = mujoco.MjData(m)
    d.qvel[:] = 1e300
    for i in range(4):
        mujoco.mj_getState(m, d, state[i], mujoco.mjtState.mjSTATE_FULLPHYSICS)
    with rollout.Rollout(nthread=2) as r:  # from rollout's own threads
        r.rollout([m] * 4, [mujoco.MjData(m) for _ in range(2)], state, nstep=3)
    print(os.path.exists("MUJOCO_LOG.TXT"))
    """
)


def blow_up(tmp_path, install: str) -> subprocess.CompletedProcess:
    code = BLOW_UP.format(install=install)
    return subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=120
    )


def test_a_blow_up_writes_no_log_file_into_the_working_folder(tmp_path):
    install = (
        "from app.robots.mujoco_warnings import keep_warnings_out_of_the_folder\n"
        "keep_warnings_out_of_the_folder()"
    )
    done = blow_up(tmp_path, install)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "False" and list(tmp_path.iterdir()) == []
    assert done.stderr.count("mujoco: Nan, Inf or huge value in QVEL") == 4  # logged, each run


def test_without_it_mujoco_writes_its_log_where_it_runs(tmp_path):
    """What the handler prevents (MuJoCo's default), so the test above can fail."""
    done = blow_up(tmp_path, "")
    assert done.stdout.strip().endswith("True") and (tmp_path / "MUJOCO_LOG.TXT").exists()


def test_every_artro_command_keeps_them_out():
    assert main(["robot", "list"]) == 0
    assert mujoco.get_mju_user_warning() is log_warning
