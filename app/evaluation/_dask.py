"""Evaluations on a Dask distributed cluster (docs/DESIGN.md §9, docs/CLUSTER.md):
`ChunkedEvaluator` on a Dask client, the runs sent to the workers as plain data (the robot's
description, the parameter sets, the variations' text), never as pickled models. The address is
checked (`check_address`) and a scheduler's answer awaited within `CONNECT_TIMEOUT_S` (`probe`)
before a client is made: Dask's own waits without end on a port that accepts and never answers."""

from __future__ import annotations

import asyncio
import socket
import sys
from collections.abc import Callable
from concurrent.futures import CancelledError, ThreadPoolExecutor
from typing import Any

from app.assets import project_version
from app.evaluation._api import ExecutorError
from app.evaluation._chunks import RUNS_PER_TASK, ChunkedEvaluator, evaluate_chunk
from app.robots.model import RobotModel

CONNECT_TIMEOUT_S = 10
WAIT_WORKERS_S = 60.0  # how long a scheduler without a worker is waited on (--wait-workers)
ADDRESS_FORMS = (
    "allowed for --cluster: tcp://HOST:PORT (or HOST:PORT) of a Dask scheduler, PORT 1-65535; "
    "tls://, ucx://, ws:// and inproc:// are not supported"
)


class ClusterError(ExecutorError):
    """The scheduler cannot be reached or went away, or a worker cannot take our runs."""


def check_address(text: str) -> str:
    """The scheduler's address as tcp://HOST:PORT, or ClusterError saying what is allowed (the
    form only: nothing is reached)."""
    text = text.strip()
    if not text:
        raise ClusterError(f"an empty scheduler address; {ADDRESS_FORMS} (without --cluster the "
                           f"runs stay on this machine)")  # fmt: skip
    scheme, sep, rest = text.partition("://")
    if not sep:
        scheme, rest = "tcp", text
    if scheme.lower() != "tcp":
        raise ClusterError(f"unsupported scheduler address {text!r}; {ADDRESS_FORMS}")
    host, colon, port = rest.rpartition(":")
    if host.startswith("[") and host.endswith("]"):
        host = host[1:-1]  # an IPv6 address
    if not colon or not host or "/" in host or not port:
        raise ClusterError(f"{text!r} is not HOST:PORT; {ADDRESS_FORMS}")
    if not port.isdigit() or not 1 <= int(port) <= 65535:
        raise ClusterError(
            f"the port in {text!r} is invalid: a port is 1 to 65535; {ADDRESS_FORMS}"
        )
    return f"tcp://{rest}"


def probe(address: str, timeout_s: float = CONNECT_TIMEOUT_S) -> dict[str, Any]:
    """What the Dask scheduler at `address` (tcp://HOST:PORT) says of itself (its identity: its
    workers among it), within `timeout_s`; ClusterError, in a sentence, when nothing accepts
    connections there, or what does is no Dask scheduler or does not answer in time."""
    host, _, port = address.removeprefix("tcp://").rpartition(":")
    host = host.strip("[]")
    try:
        socket.create_connection((host, int(port)), timeout=timeout_s).close()
    except socket.gaierror as exc:
        raise ClusterError(f"no Dask scheduler at {address}: the host {host!r} is not known "
                           f"({exc.strerror})") from None  # fmt: skip
    except TimeoutError:
        raise ClusterError(f"no Dask scheduler answers at {address}: no connection within "
                           f"{timeout_s:g} s") from None  # fmt: skip
    except OSError as exc:
        raise ClusterError(f"no Dask scheduler answers at {address}: "
                           f"{exc.strerror or exc}") from None  # fmt: skip
    with ThreadPoolExecutor(1) as pool:  # its own event loop, whatever the caller's thread runs
        try:
            found = pool.submit(asyncio.run, _identity(address, timeout_s)).result()
        except TimeoutError:
            raise ClusterError(
                f"something at {address} accepts connections but gives no Dask scheduler's "
                f"answer within {timeout_s:g} s; is that the scheduler's port (8786 by default)?"
            ) from None
        except Exception:  # another protocol's bytes read as Dask's (HTTP, ...): no use to say
            raise ClusterError(
                f"the server at {address} is not a Dask scheduler (its answer is not Dask's "
                f"protocol); is that the scheduler's port (8786 by default, not its "
                f"dashboard's)?"
            ) from None
    if not isinstance(found, dict) or found.get("type") != "Scheduler":
        kind = found.get("type") if isinstance(found, dict) else type(found).__name__
        raise ClusterError(f"{address} is a Dask {kind}, not the scheduler; give the "
                           f"scheduler's address") from None  # fmt: skip
    return found


async def _identity(address: str, timeout_s: float) -> Any:
    from distributed.comm import connect

    async def ask() -> Any:
        comm = await connect(address, timeout=timeout_s)
        try:
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    return await asyncio.wait_for(ask(), timeout_s)


def _client(address: str) -> Any:
    """A Dask client of the scheduler at `address`; one whose start fails is closed (else its
    `__del__` tries, 20 s later, and prints a traceback)."""
    from distributed import Client

    made: list[Client] = []

    class Kept(Client):
        def start(self, **kwargs: Any) -> None:
            made.append(self)
            super().start(**kwargs)

    try:
        return Kept(address, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
    except BaseException:
        for client in made:
            _close(client)
        raise


def _close(client: Any) -> None:
    try:
        client.close(timeout=CONNECT_TIMEOUT_S)
    except Exception:  # a client that cannot close cleanly is gone all the same
        pass


def worker_version() -> str:
    """What a worker reports when asked (runs on the worker)."""
    return project_version()


class ClusterEvaluator(ChunkedEvaluator):
    """`Evaluator` on the Dask scheduler at `address`. A worker that dies loses no result: its
    tasks run again on another (Dask recomputes what a lost worker held); a scheduler that goes
    away is a ClusterError; so is a worker of another project version, naming both."""

    def __init__(
        self,
        address: str,
        robot: RobotModel,
        *,
        runs_per_task: int = RUNS_PER_TASK,
        wait_workers_s: float = WAIT_WORKERS_S,
        say: Callable[[str], None] | None = None,
    ):
        try:
            import distributed  # noqa: F401
        except ImportError as exc:  # the optional extra
            raise ClusterError(
                "a cluster needs Dask, the cluster extra: in the project's folder, "
                'pip install -e ".[cluster]"'
            ) from exc
        super().__init__(robot)
        self.address = check_address(address)
        self.runs_per_task = runs_per_task
        found = probe(self.address)
        try:
            self.client = _client(self.address)
        except (OSError, TimeoutError) as exc:
            raise ClusterError(f"no Dask scheduler answers at {self.address}: {exc}") from exc
        try:
            if not found.get("workers"):
                self._wait_for_a_worker(wait_workers_s, say or _say)
            self.check_versions()
        except BaseException:
            self.close()
            raise

    def _wait_for_a_worker(self, wait_s: float, say: Callable[[str], None]) -> None:
        """Say that no worker is there, then wait up to `wait_s` for one; ClusterError after."""
        if self.workers():
            return  # one came while the client connected
        say(
            f"connected to the Dask scheduler at {self.address}; no worker connected yet, "
            f"waiting up to {wait_s:g} s (--wait-workers)"
        )
        try:
            if wait_s <= 0:  # Dask's wait takes 0 as "for ever"
                raise TimeoutError
            self.client.wait_for_workers(1, timeout=wait_s)
        except (TimeoutError, OSError):
            raise ClusterError(
                f"no worker connected to the Dask scheduler at {self.address} within {wait_s:g} "
                f"s; start one (dask worker {self.address}, docs/CLUSTER.md) or wait longer "
                f"with --wait-workers SECONDS"
            ) from None
        say(f"a worker connected to {self.address}; going on")

    def check_versions(self) -> None:
        """ClusterError if a worker runs another version of the project (or none)."""
        ours = project_version()
        try:
            found = self.client.run(worker_version)
        except Exception as exc:  # a worker without the project cannot even import this
            raise ClusterError(f"the workers at {self.address} cannot run artro: {exc}") from exc
        other = {w: v for w, v in found.items() if v != ours}
        if other:
            listed = ", ".join(f"{w} runs {v}" for w, v in sorted(other.items()))
            raise ClusterError(f"this is artro-gait-studio {ours}; refused workers: {listed}")

    def workers(self) -> int:
        return len(self.client.scheduler_info().get("workers", {}))

    def close(self) -> None:
        _close(self.client)

    def task_size(self, runs: int) -> int:
        return self.runs_per_task

    def lanes(self) -> int:
        return max(1, sum(self.client.nthreads().values()))

    def _submit(self, chunk: list[dict[str, Any]], *args: Any) -> Any:
        return self.client.submit(
            evaluate_chunk, self._robot_json, chunk, *args, pure=False, retries=1
        )

    def _lost(self, exc: BaseException, done: int, total: int) -> Exception | None:
        if not isinstance(exc, OSError | TimeoutError | CancelledError):
            return None  # Dask's errors when it lost the line to the scheduler
        return ClusterError(
            f"the Dask scheduler at {self.address} went away ({type(exc).__name__}: {exc}); "
            f"the runs not finished have no result"
        )


def _say(line: str) -> None:
    print(line, file=sys.stderr, flush=True)
