"""Where an `artro` command's runs compute: `--threads`, `--cluster` and `--wait-workers`,
`--backend` and `--device`, and what they mean to `evaluator_for` (docs/DESIGN.md §9, docs/GPU.md,
docs/CLUSTER.md)."""

from __future__ import annotations

import argparse
from typing import Any

from app.cli._arg_types import cluster_address, number


def add_threads_option(
    parser: Any, what: str = "simulation threads", default: str = "all cores"
) -> None:
    """`--threads N`: how many threads step the physics on this machine."""
    parser.add_argument(
        "--threads",
        type=number(1, 1024, integer=True, what="--threads"),
        default=None,
        metavar="N",
        help=f"{what} (default: {default})",
    )


def add_cluster_options(parser: Any, purpose: str, *, wait: bool = True) -> None:
    """`--cluster tcp://HOST:PORT` (checked as it is parsed) and, with `wait`, `--wait-workers`."""
    parser.add_argument(
        "--cluster",
        type=cluster_address,
        metavar="tcp://HOST:PORT",
        help=f"{purpose} (default: none, this machine)",
    )
    if wait:
        parser.add_argument(
            "--wait-workers",
            type=number(0, 86_400, what="--wait-workers"),
            default=None,
            metavar="S",
            help="with --cluster: how long to wait for a worker when the scheduler has none "
            "(default 60 s; it says so at once), then give up with exit status 2",
        )


def add_backend_options(parser: Any) -> None:
    """`--backend cpu|warp|auto` and `--device cpu|cuda` (docs/GPU.md), read by `backend_of`;
    argparse refuses another value, naming those allowed (exit status 2)."""
    from app.evaluation import BACKENDS, DEVICES

    parser.add_argument(
        "--backend",
        choices=BACKENDS,
        default="cpu",
        help="who steps the physics: cpu (MuJoCo's threads, processes or --cluster; default), "
        "warp (every run of a call a world of one MuJoCo Warp batch; the gpu extra, "
        "docs/GPU.md) or auto (warp when a CUDA device and the extra are there)",
    )
    parser.add_argument(
        "--device",
        choices=DEVICES,
        default=None,
        help="with --backend warp: cuda (default) or cpu (Warp's CPU device: slow, for checks)",
    )


def cluster_of(args: argparse.Namespace) -> dict[str, Any]:
    """`--cluster` and `--wait-workers` as the evaluator's `cluster` and `wait_workers_s`;
    ValueError for --wait-workers without a cluster to wait for."""
    wait = getattr(args, "wait_workers", None)
    if wait is not None and args.cluster is None:
        raise ValueError("--wait-workers is how long to wait for a --cluster's workers; give both")
    return {"cluster": args.cluster, "wait_workers_s": wait}


def backend_of(args: argparse.Namespace) -> dict[str, Any]:
    """`evaluator_for`'s backend and device from `add_backend_options`' options; ValueError for
    --device without a backend that uses it."""
    if args.device is not None and args.backend == "cpu":
        raise ValueError(f"--device {args.device} is for --backend warp or auto, not cpu")
    if args.backend == "warp" and getattr(args, "cluster", None) is not None:
        raise ValueError("--backend warp runs in this process: leave out --cluster")
    return {"backend": args.backend, "device": args.device}
