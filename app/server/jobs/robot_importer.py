"""The dashboard's robot import: an upload unpacked (`robot_upload`), then `artro robot import`'s
own import run in a child process with a deadline, off the event loop and the simulation thread,
so a file that makes MuJoCo hang ends the child, not the server; one at a time, cancellable; the
robot then on the shelf. On any refusal its folder goes: nothing half-imported (§16)."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from app.robots.cad_import import DEFAULT_SERVO, import_robot, mapping_rows, name_of, write_import
from app.robots.model import RobotModel
from app.server.http.robot_upload import unpack, upload_name
from app.server.robot_shelf import RobotShelf

#: how long the child may take: ArtRo's export imports in about 3 s, the child's start included;
#: a file taking 40 times that is refused rather than waited for (a setting: `ServerConfig`)
IMPORT_TIMEOUT_S = 120.0
#: the child's address space: ArtRo's import takes 0.2 GB, so meshes have room; a file that asks
#: for more is refused rather than let press on the server's memory
MAX_CHILD_MEMORY_BYTES = 4 * 1024**3
#: the child: `artro robot import`'s functions, the notes as JSON on its last line (exit 2: why)
CHILD = "from app.server.jobs.robot_importer import child_main; child_main()"


class ImportBusy(RuntimeError):
    """Another import runs: one at a time."""


class ImportFailed(ValueError):
    """The import refused, timed out or was cancelled; `kind` says which, the message why."""

    def __init__(self, message: str, kind: str) -> None:
        super().__init__(message)
        self.kind = kind


@dataclass(frozen=True)
class ImportOptions:
    """What `artro robot import` takes besides the file (the zip's robot file: `file`)."""

    name: str | None = None
    servo: str = DEFAULT_SERVO
    keep_actuators: bool = False
    forward: str | None = None
    file: str | None = None


class RobotImporter:
    def __init__(
        self, shelf: RobotShelf, folder: Path, timeout_s: float = IMPORT_TIMEOUT_S
    ) -> None:
        """Uploads go under `folder` (the data folder's robots/), each in its own."""
        self.shelf, self.folder, self.timeout_s = shelf, folder, timeout_s
        self._lock = threading.Lock()
        self._child: subprocess.Popen[str] | None = None
        self._cancelled = False

    def run(self, body: bytes, filename: str, options: ImportOptions) -> dict[str, Any]:
        """Import the upload and put the robot on the shelf; what the dashboard shows of it.
        ImportBusy, UploadRefused, ImportFailed (each with nothing left on disk or shelf)."""
        if not self._lock.acquire(blocking=False):
            raise ImportBusy("another robot is being imported: wait for it or cancel it")
        try:
            self._cancelled = False
            upload_name(filename)
            wanted = options.name or name_of(Path(filename))
            name = self._free_name(wanted)
            folder = self.folder / name
            try:
                unpacked = unpack(body, filename, folder, options.file)
                target = folder / f"{name}.yaml"
                notes = self._import(unpacked.robot_file, target, name, options)
                try:
                    model = RobotModel.load(target)
                except ValueError as exc:  # built in the child: only a file changed since
                    raise ImportFailed(str(exc), "refused") from None
                self.shelf.add(model)
            except BaseException:
                shutil.rmtree(folder, ignore_errors=True)
                raise
            if name != wanted:
                notes.insert(0, f"named {name}: a robot named {wanted} is on offer already")
            return _answer(model, unpacked.robot_file.relative_to(folder), target, notes)
        finally:
            self._child = None
            self._lock.release()

    def cancel(self) -> bool:
        """Stop the import that runs (its child killed); whether one ran."""
        child = self._child
        if child is None:
            return False
        self._cancelled = True
        _kill(child)
        return True

    def _free_name(self, wanted: str) -> str:
        offered = set(self.shelf.names())
        name, n = wanted, 1
        while name in offered or (self.folder / name).exists():
            n += 1
            name = f"{wanted[:36]}-{n}"
        return name

    def _import(self, source: Path, target: Path, name: str, options: ImportOptions) -> list[str]:
        folder = str(target.parent)
        argv = [str(source), str(target), json.dumps(asdict(options) | {"name": name})]
        child = subprocess.Popen(
            [sys.executable, "-c", CHILD, *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            stdin=subprocess.DEVNULL, text=True, cwd=folder, start_new_session=True,
            env=os.environ | {"PYTHONUNBUFFERED": "1"},
        )  # fmt: skip
        self._child = child
        if self._cancelled:  # cancelled between the check and the start
            _kill(child)
        try:
            out, err = child.communicate(timeout=self.timeout_s)
        except subprocess.TimeoutExpired:
            _kill(child)
            raise ImportFailed(
                f"the import took longer than {self.timeout_s:g} s and was stopped: MuJoCo may "
                "hang on this file, or its meshes are too many or too fine",
                "timed_out",
            ) from None
        if self._cancelled:
            raise ImportFailed("the import was cancelled; nothing was imported", "cancelled")
        if child.returncode == 0:
            return list(json.loads(out.strip().splitlines()[-1])["notes"])
        said = [
            line.removeprefix("error: ") for line in err.splitlines() if line.startswith("error: ")
        ]
        if said:
            reason = said[-1].replace(folder + os.sep, "").replace(folder, ".")
            if "mesh file(s) not found" in reason:  # the CLI's advice, in an upload's words
                reason = re.sub(r" \(looked beside the file[^)]*\)", "", reason) + (
                    ": upload a .zip of the robot file with its meshes, where the file names them"
                )
        elif child.returncode < 0:
            reason = f"MuJoCo crashed on the file (signal {-child.returncode})"
        else:
            reason = f"the import failed: {(err.strip().splitlines() or ['no word'])[-1]:.200}"
        raise ImportFailed(reason, "refused")


def _kill(child: subprocess.Popen[str]) -> None:
    if child.poll() is None:
        try:
            os.killpg(child.pid, signal.SIGKILL)  # the child and anything it started
        except ProcessLookupError:
            pass


def _answer(model: RobotModel, source: Path, written: Path, notes: list[str]) -> dict[str, Any]:
    desc = model.description
    cad = desc.cad
    assert cad is not None
    return {
        "robot": model.name,
        "title": desc.title,
        "file": source.as_posix(),
        "written": str(written),
        "total_mass_kg": model.total_mass_kg(),
        "leg_m": model.geometry.upper_m + model.geometry.lower_m,
        "geometry": desc.geometry.model_dump(mode="json"),
        "forward_from": cad.forward_from,
        "mapping": mapping_rows(desc),
        "held": list(cad.held),
        "notes": notes,
    }


def child_main() -> None:
    """The child's work: `artro robot import SOURCE -o TARGET` with the options, and the model
    built; the notes as JSON on stdout, or `error: WHY` on stderr and exit status 2."""
    import resource

    from app.robots.mujoco_warnings import keep_warnings_out_of_the_folder

    resource.setrlimit(resource.RLIMIT_AS, (MAX_CHILD_MEMORY_BYTES, MAX_CHILD_MEMORY_BYTES))
    keep_warnings_out_of_the_folder()
    source, target, given = Path(sys.argv[1]), Path(sys.argv[2]), json.loads(sys.argv[3])
    options = ImportOptions(**given)
    try:
        imported = import_robot(
            source, output=target, name=options.name, servo=options.servo,
            keep_actuators=options.keep_actuators, forward=options.forward,
            package_dirs=(str(target.parent),),  # package://PKG/... within the upload
        )  # fmt: skip
        write_import(imported, target, f"the dashboard's import of {source.name}")
        RobotModel.load(target)  # built here too: a build that hangs hangs the child
    except (ValueError, OSError) as exc:
        print("error: " + " ".join(str(exc).split()), file=sys.stderr, flush=True)
        sys.exit(2)
    except MemoryError:
        limit = MAX_CHILD_MEMORY_BYTES // 1024**3
        print(f"error: the import needed more than {limit} GiB of memory", file=sys.stderr)
        sys.exit(2)
    print(json.dumps({"notes": imported.notes}), flush=True)
