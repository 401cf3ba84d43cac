"""MuJoCo's warnings kept out of the working folder: its own handler prints each and appends it
to MUJOCO_LOG.TXT wherever the command runs. A run's blow-up is reported in its metrics and
checks (`blew_up`, docs/DESIGN.md §14), so the message goes to the `mujoco` logger instead."""

from __future__ import annotations

import logging

import mujoco

LOG = logging.getLogger("mujoco")


def log_warning(message: str) -> None:
    """MuJoCo's warning, at INFO level (rollout's threads call it, holding the GIL)."""
    LOG.info("%s", message)


def keep_warnings_out_of_the_folder() -> None:
    """Route every MuJoCo warning of this process to `log_warning`."""
    mujoco.set_mju_user_warning(log_warning)
