"""`artro serve`: the dashboard (simulation, API, 3D view and scope page) on one port."""

from __future__ import annotations

import argparse
import dataclasses
import sys
from typing import Any

from app.cli.firmware_flash import add_board_option
from app.cli.options import (
    add_backend_options,
    add_cluster_options,
    add_params_option,
    add_robot_option,
    backend_of,
    cluster_of,
    host_name,
    number,
    output_folder,
    resolve_set,
    subcommand,
)
from app.robots.model import RobotModel

EXAMPLES = """examples:
  artro serve                              the dashboard on http://localhost:8000
  artro serve --params my_gait.json --port 9000
  artro serve --params tuned               start with a preset, built in or saved, by name
  artro serve --drive firmware             pulses from the robot's firmware on an emulated MCU
  artro serve --drive firmware --board mega2560-pca9685   on a Mega and its PCA9685 (docs/BOARDS.md)
  artro serve --servo-bus pty              the leg servos on a virtual Dynamixel bus too"""


def add_parser(sub: Any) -> None:
    s = subcommand(
        sub, "serve", "the dashboard: simulation, API, 3D view and scope page", serve, EXAMPLES
    )
    s.add_argument(
        "--host",
        type=host_name,
        default="127.0.0.1",
        help="address to listen on (default 127.0.0.1; 0.0.0.0 for every interface)",
    )
    s.add_argument(
        "--port",
        type=number(1, 65535, integer=True, what="--port"),
        default=8000,
        help="HTTP port of the dashboard and API",
    )
    s.add_argument(
        "--viser-port",
        type=number(0, 65535, integer=True, what="--viser-port"),
        default=8080,
        help="port of the viser 3D view (taken: the next free one; 0: any free port; "
        "GET /api/health says which)",
    )
    add_params_option(s, "the --robot's default preset")
    add_robot_option(s)
    add_cluster_options(
        s,
        "run the dashboard's robustness and fit jobs on this Dask scheduler (docs/CLUSTER.md)",
    )
    add_backend_options(s)  # the robustness job's; the live simulation is always MuJoCo's
    s.add_argument(
        "--data-dir",
        type=output_folder,
        metavar="DIR",
        help="where presets are saved "
        "(default: $ARTRO_DATA_DIR, else $XDG_DATA_HOME/artro-gait-studio or "
        "~/.local/share/artro-gait-studio)",
    )
    s.add_argument("--no-viewer", action="store_true", help="run without the viser 3D view")
    s.add_argument(
        "--drive",
        choices=("model", "firmware"),
        default="model",
        help="who makes the servo pulses: the Python hardware model (default) or the robot's "
        "firmware on its emulated board (--board; needs gcc-avr and simavr); switchable in the "
        "page",
    )
    add_board_option(s)  # the firmware drive's
    s.add_argument(
        "--servo-bus",
        choices=("pty",),
        default=None,
        help="pty: the robot's 12 leg servos also answer on a pseudo-terminal as bus servos, "
        "its path printed at the start; a program's goal writes drive the robot (default: "
        "none; docs/BUS.md)",
    )
    s.add_argument(
        "--bus-protocol",
        choices=("dynamixel", "feetech"),
        default="dynamixel",
        help="the --servo-bus's servos: Dynamixel Protocol 2.0 XM430s (default) or Feetech STS",
    )
    s.add_argument(
        "--allowed-host",
        action="append",
        default=[],
        metavar="NAME",
        help="also serve requests for this Host name (repeatable); localhost, 127.0.0.1, ::1 "
        "and the bind host always are, others are refused against DNS rebinding",
    )


def serve(args: argparse.Namespace) -> int:
    import uvicorn

    from app.firmware.build import missing_tools
    from app.params.presets import default_data_dir
    from app.server.http.app import UVICORN_OPTIONS, create_app
    from app.server.robot_shelf import RobotShelf
    from app.server.services import ServerConfig

    data_dir = args.data_dir or default_data_dir()
    if data_dir.exists() and not data_dir.is_dir():  # $ARTRO_DATA_DIR as --data-dir is checked
        raise ValueError(f"the data folder {data_dir} is a file, not a folder")
    # a file, or a preset's name (built in or saved in --data-dir): read here, before serving
    chosen = resolve_set(args.params, "--params", data_dir) if args.params else None
    config = ServerConfig(
        host=args.host,
        port=args.port,
        viser_port=args.viser_port,
        params_file=chosen.path if chosen else None,
        robot=args.robot,
        **cluster_of(args),
        **backend_of(args),
        data_dir=data_dir,
        viewer=not args.no_viewer,
        allowed_hosts=tuple(args.allowed_host),
        drive=args.drive,
        board=args.board,
        servo_bus=args.servo_bus,
        bus_protocol=args.bus_protocol,
    )
    robot = RobotModel.load(args.robot)
    RobotShelf(robot)  # fail here, clearly, not inside the server
    if args.board and robot.hardware().bus is not None:
        raise ValueError(
            f"--board {args.board}: the robot {robot.name!r} has bus servos, which no firmware "
            "board drives (the host sync-writes them, docs/BUS.md): leave --board out"
        )
    check_port_free(args.host, args.port)  # before the banner names it (uvicorn's error: raw)
    if not args.no_viewer:  # and the 3D view's, the banner naming the one it gets
        args.viser_port = viser_port_for(args.host, args.viser_port, args.port)
        config = dataclasses.replace(config, viser_port=args.viser_port)
    if config.backend != "cpu":  # a missing extra or CUDA device: here, not in the first job
        from app.evaluation import close_evaluator, evaluator_for

        close_evaluator(
            evaluator_for(RobotModel.load(args.robot), backend=config.backend, device=config.device)
        )
    if config.drive == "firmware" and (missing := missing_tools()):
        print(f"artro serve --drive firmware: missing {', '.join(missing)}", file=sys.stderr)
        print("install them with: bash scripts/setup.sh", file=sys.stderr)
        return 2
    app = create_app(config)
    print(banner(args), flush=True)
    options: dict[str, Any] = dict(UVICORN_OPTIONS)  # uvicorn.run types each keyword
    uvicorn.run(app, host=args.host, port=args.port, log_level="warning", **options)
    return 0


def banner(args: argparse.Namespace) -> str:
    """The line that says where the page, the 3D view (none with --no-viewer) and the API's docs
    are; a 3D view's port that is taken is said by the server once it knows the next."""
    from app.server.view.viser_view import viser_url

    url = viser_url(args.host, args.port)
    if args.no_viewer:
        view = ""
    elif args.viser_port == 0:  # known once it listens
        view = "3D view alone: a free port, GET /api/health names it, "
    else:
        view = f"3D view alone: {viser_url(args.host, args.viser_port)}, "
    return f"ArtRo Gait Studio: {url}  ({view}API docs: {url}/docs)"


def bind_error(host: str, port: int) -> OSError | None:
    """Why `port` on `host` cannot be listened on (bound as uvicorn binds), or None."""
    import socket

    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    with socket.socket(family, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind((host, port))
        except OSError as exc:
            return exc
    return None


def check_port_free(host: str, port: int) -> None:
    """OSError naming the --port if something listens on it already."""
    if exc := bind_error(host, port):
        raise OSError(
            f"--port {port} on {host} is taken ({exc.strerror or exc}): another server, "
            "maybe another artro serve, listens there; give another --port"
        ) from None


def viser_port_for(host: str, wanted: int, page_port: int) -> int:
    """The 3D view's port: `wanted`, or where it is taken the next free one that is not the
    page's own (viser would take that, and the page could then not listen); 0 stays 0 (any
    free port, chosen as viser starts)."""
    if wanted == 0:
        return 0
    for port in range(wanted, min(wanted + 100, 65_536)):
        if port != page_port and bind_error(host, port) is None:
            if port != wanted:
                print(f"artro serve: port {wanted} is taken; the 3D view alone is on {port}",
                      file=sys.stderr)  # fmt: skip
            return port
    raise OSError(f"--viser-port {wanted} and the 99 ports after it are taken; give another")
