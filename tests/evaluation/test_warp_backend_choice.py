"""Choosing the MuJoCo Warp executor (docs/GPU.md): `--backend auto` says what it chose and why,
a missing CUDA device names the CPU device, a missing extra the pip command, and a bad backend
or device is refused (the CLI with exit status 2); `bench robust` on the Warp backend."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from app.evaluation import (
    BatchEvaluator,
    ExecutorError,
    close_evaluator,
    evaluator_for,
)
from app.evaluation._warp import WarpEvaluator
from app.robots.model import RobotModel


@pytest.fixture(scope="module")
def robot():
    return RobotModel.load()


def test_no_cuda_device_names_the_cpu_device(robot):
    import warp as wp

    if wp.get_cuda_device_count() > 0:
        pytest.skip("this machine has a CUDA device")
    with pytest.raises(ExecutorError, match=r"no CUDA device.*--device cpu"):
        evaluator_for(robot, backend="warp", device="cuda")
    with pytest.raises(ExecutorError, match=r"no CUDA device.*--device cpu"):
        evaluator_for(robot, backend="warp")  # cuda is the default device


def test_auto_without_a_cuda_device_is_the_cpu_executor(robot):
    import warp as wp

    if wp.get_cuda_device_count() > 0:
        pytest.skip("this machine has a CUDA device")
    said: list[str] = []
    assert isinstance(evaluator_for(robot, backend="auto", notice=said.append), BatchEvaluator)
    assert said == ["--backend auto: the CPU's executors: Warp finds no CUDA device (cuda)"]


def test_auto_says_what_it_chose_and_why_and_honours_the_device(robot):
    """Issue 56 item 14: `--backend auto` chose in silence, and ran the CPU's executors where
    --device cpu asked for Warp's CPU device. With a CUDA device (a GPU machine) it names it."""
    import warp as wp

    said: list[str] = []
    on_cpu = evaluator_for(robot, backend="auto", device="cpu", notice=said.append)
    try:
        assert isinstance(on_cpu, WarpEvaluator)
    finally:
        close_evaluator(on_cpu)
    assert (
        said[0] == "--backend auto: MuJoCo Warp on Warp's CPU device, as --device cpu asks (slow)"
    )
    elsewhere = evaluator_for(robot, backend="auto", processes=1, notice=said.append)
    close_evaluator(elsewhere)
    assert said[-1] == (
        "--backend auto: the CPU's executors, as --processes asks (Warp runs in this process)"
    )
    if wp.get_cuda_device_count() > 0:  # the GPU machine
        chosen = evaluator_for(robot, backend="auto", notice=said.append)
        try:
            assert isinstance(chosen, WarpEvaluator)
        finally:
            close_evaluator(chosen)
        name = wp.get_device("cuda").name
        assert said[-1] == (
            f"--backend auto: MuJoCo Warp on cuda ({name}): the gpu extra and a CUDA device"
        )


def test_an_unknown_backend_or_device_says_what_is_allowed(robot):
    with pytest.raises(ExecutorError, match="backend must be one of cpu, warp, auto, got 'gpu'"):
        evaluator_for(robot, backend="gpu")
    with pytest.raises(ExecutorError, match="--device must be one of cpu, cuda, got 'tpu'"):
        evaluator_for(robot, backend="warp", device="tpu")
    with pytest.raises(ExecutorError, match=r"worker processes \(processes=\) are the CPU's"):
        evaluator_for(robot, backend="warp", device="cpu", processes=2)
    with pytest.raises(ExecutorError, match=r"one batch: leave out --cluster$"):
        evaluator_for(robot, backend="warp", device="cpu", cluster="tcp://127.0.0.1:1")


def test_a_missing_extra_names_the_pip_command():
    """MuJoCo Warp made unimportable in a fresh interpreter: a real ImportError."""
    code = (
        "import sys; sys.modules['mujoco_warp'] = None\n"
        "from app.evaluation import ExecutorError, evaluator_for\n"
        "from app.robots.model import RobotModel\n"
        "try:\n"
        "    evaluator_for(RobotModel.load(), backend='warp', device='cpu')\n"
        "except ExecutorError as error:\n"
        "    print(error)\n"
        "else:\n"
        "    print('no error')\n"
        "from app.evaluation import BatchEvaluator\n"
        "print(type(evaluator_for(RobotModel.load(), backend='auto')).__name__)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True
    )
    error, auto = out.stdout.strip().splitlines()
    assert "needs MuJoCo Warp" in error and 'pip install -e ".[gpu]"' in error
    assert auto == "BatchEvaluator"  # auto falls back to the CPU's executors without the extra
    assert "--backend auto: the CPU's executors: MuJoCo Warp is not installed" in out.stderr


def artro(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "app.cli", *args], capture_output=True, text=True, timeout=600
    )


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (
            ("bench", "robust", "--backend", "gpu"),
            "invalid choice: 'gpu' (choose from {cpu}, {warp}, {auto})",
        ),
        (("tune", "--device", "tpu"), "invalid choice: 'tpu' (choose from {cpu}, {cuda})"),
        (
            ("calibrate-ca", "--device", "cpu"),
            "--device cpu is for --backend warp or auto, not cpu",
        ),
        (
            ("bench", "paper", "--backend", "warp", "--cluster", "tcp://127.0.0.1:1"),
            "--backend warp runs in this process: leave out --cluster",
        ),
    ],
)
def test_the_cli_refuses_a_bad_backend_or_device_with_exit_status_2(args, said):
    """argparse quotes the choices or not, by Python version."""
    done = artro(*args)
    names = ("cpu", "warp", "auto", "cuda")
    quoted = said.format(**{n: f"'{n}'" for n in names})
    plain = said.format(**{n: n for n in names})
    assert done.returncode == 2, done.stderr
    assert quoted in done.stderr or plain in done.stderr, done.stderr


@pytest.mark.parametrize(
    "args",
    [
        ("bench", "robust", "--samples", "1"),
        ("serve", "--no-viewer", "--port", "1"),  # before it listens: its robustness job's
    ],
)
def test_the_cli_without_a_cuda_device_names_the_cpu_device(args):
    import warp as wp

    if wp.get_cuda_device_count() > 0:
        pytest.skip("this machine has a CUDA device")
    done = artro(*args, "--backend", "warp")
    assert done.returncode == 2 and "no CUDA device" in done.stderr, done.stderr
    assert "--device cpu" in done.stderr


@pytest.mark.slow
def test_bench_robust_runs_on_the_warp_backend_and_says_it_compiles(tmp_path):
    done = artro(
        "bench", "robust", "--backend", "warp", "--device", "cpu", "--samples", "1",
        "--duration", "2", "--warmup", "0.5", "--json", "--out", str(tmp_path),
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "warp: compiling MuJoCo Warp's kernels for device cpu" in done.stderr
    (report,) = json.loads(done.stdout)["presets"]
    assert len(report["cases"]) == 9 and all(c["runs"] == 1 for c in report["cases"])
