"""A robot file uploaded to the dashboard, hostile until read: a URDF, an MJCF or a zip of one with
its meshes, held to named caps; no name or file reference that leaves the upload's folder, no link,
no DTD or entity. Written into a fresh folder only once every check passed (`unpack`);
`UploadRefused` says what is wrong and what is allowed."""

from __future__ import annotations

import io
import posixpath
import re
import shutil
import stat
import zipfile
from dataclasses import dataclass
from pathlib import Path
from xml.etree import ElementTree

#: the body's cap: a humanoid's URDF with decimated STL meshes is a few MB (OP3's: 4 MB)
MAX_UPLOAD_BYTES = 20 * 1024 * 1024
#: members of a zip: a robot file and a mesh or two per link (OP3's package: about 40)
MAX_ZIP_FILES = 200
#: what a zip unpacks to, counted as it unpacks whatever its directory claims (a zip bomb)
MAX_UNPACKED_BYTES = 50 * 1024 * 1024
#: a name's bytes (a file name on most file systems) and a zip's folders within folders
MAX_NAME_BYTES = 255
MAX_DEPTH = 8
ROBOT_SUFFIXES = (".urdf", ".xml")
UPLOAD_SUFFIXES = (*ROBOT_SUFFIXES, ".zip")
ROBOT_ROOTS = ("robot", "mujoco")  # URDF's root element, MJCF's
#: an MJCF attribute naming a folder the file names below it are relative to
DIR_ATTRIBUTES = ("meshdir", "texturedir", "assetdir")
#: what a zip made on a Mac or Windows carries besides its files; skipped, never written
JUNK = re.compile(r"(^|/)(__MACOSX/|\.DS_Store$|Thumbs\.db$)")
_CHUNK = 1 << 16


class UploadRefused(ValueError):
    """An upload refused before anything was written: what is wrong and what is allowed."""


@dataclass(frozen=True)
class Unpacked:
    """Where an upload was written: its folder, the robot file in it, how many files."""

    folder: Path
    robot_file: Path
    files: int


def upload_name(filename: str) -> str:
    """The upload's file name as given, if allowed: a plain name ending .urdf, .xml or .zip."""
    if not filename or len(filename.encode()) > MAX_NAME_BYTES:
        raise UploadRefused(f"the file's name must have 1 to {MAX_NAME_BYTES} bytes")
    if any(c in filename for c in "/\\\0") or filename in (".", ".."):
        raise UploadRefused(f"{filename!r:.80}: give the file's own name, with no folder in it")
    if not filename.lower().endswith(UPLOAD_SUFFIXES):
        raise UploadRefused(
            f"{filename!r:.80}: a robot is a .urdf or an MJCF .xml file, or a .zip of one with "
            "its meshes"
        )
    return filename


def unpack(body: bytes, filename: str, folder: Path, chosen: str | None = None) -> Unpacked:
    """Check the upload `body` named `filename` and write it into `folder` (made here, which must
    not exist): a .urdf or .xml as it is, a .zip's files in their folders; `chosen` names the
    robot file in a zip holding several. UploadRefused, with nothing written, otherwise."""
    name = upload_name(filename)
    if len(body) > MAX_UPLOAD_BYTES:
        raise UploadRefused(f"{name}: {len(body)} bytes; an upload may have {MAX_UPLOAD_BYTES}")
    if name.lower().endswith(".zip"):
        files = _zip_files(body, name)
    else:
        if chosen is not None:
            raise UploadRefused("file= names the robot file within a .zip; this is one file")
        files = {name: body}
        chosen = name
    roots, includes = {}, set()
    for member, data in files.items():
        if member.lower().endswith(ROBOT_SUFFIXES):
            root = _checked_xml(member, data)
            roots[member] = root.tag
            includes |= {
                posixpath.normpath(posixpath.join(posixpath.dirname(member), e.get("file", "")))
                for e in root.iter("include")
            }
    robot = _robot_file(name, files, roots, includes, chosen)
    return _write(files, folder, robot)


def _zip_files(body: bytes, name: str) -> dict[str, bytes]:
    try:
        archive = zipfile.ZipFile(io.BytesIO(body))
        members = archive.infolist()
    except (zipfile.BadZipFile, OSError, ValueError, EOFError) as err:
        raise UploadRefused(f"{name} is no zip file MuJoCo's files can come in: {err}") from None
    if len(members) > MAX_ZIP_FILES:
        raise UploadRefused(
            f"{name} holds {len(members)} entries; a robot's zip may hold {MAX_ZIP_FILES}"
        )
    seen: dict[str, bool] = {}  # name -> is a folder
    kept = []
    for info in members:
        member = _member_name(info, name)
        if JUNK.search(info.filename):
            continue
        parents = member.split("/")[:-1]
        for i in range(1, len(parents) + 1):
            parent = "/".join(parents[:i])
            if seen.get(parent) is False:
                raise UploadRefused(f"{name}: {parent!r:.80} is both a file and a folder")
            seen[parent] = True
        if member in seen and (seen[member] is False or not info.is_dir()):
            raise UploadRefused(f"{name}: {member!r:.80} is in it twice; each name once")
        seen[member] = info.is_dir()
        if not info.is_dir():
            kept.append((member, info))
    declared = sum(info.file_size for _, info in kept)
    if declared > MAX_UNPACKED_BYTES:
        raise UploadRefused(
            f"{name} unpacks to {declared} bytes; a robot's zip may unpack to {MAX_UNPACKED_BYTES}"
        )
    files, total = {}, 0
    for member, info in kept:
        parts = []
        try:
            with archive.open(info) as stream:
                while chunk := stream.read(_CHUNK):
                    total += len(chunk)
                    if total > MAX_UNPACKED_BYTES:
                        raise UploadRefused(
                            f"{name} unpacks to more than {MAX_UNPACKED_BYTES} bytes (more than "
                            "its directory says); a robot's zip may unpack to that much"
                        )
                    parts.append(chunk)
        except (zipfile.BadZipFile, NotImplementedError, OSError, EOFError, RuntimeError) as err:
            raise UploadRefused(f"{name}: {member!r:.80} cannot be unpacked: {err}") from None
        files[member] = b"".join(parts)
    return files


def _member_name(info: zipfile.ZipInfo, name: str) -> str:
    raw = info.filename
    shown = f"{name}: {raw!r:.80}"
    if len(raw.encode()) > MAX_NAME_BYTES:
        raise UploadRefused(f"{shown}: a name within the zip may have {MAX_NAME_BYTES} bytes")
    if "\0" in raw or "\\" in raw:
        raise UploadRefused(f"{shown}: names within the zip use '/' between folders")
    if raw.startswith("/") or re.match(r"^[A-Za-z]:", raw):
        raise UploadRefused(f"{shown} is an absolute name; each must be relative to the zip")
    parts = raw.rstrip("/").split("/")
    if ".." in parts:
        raise UploadRefused(f"{shown} leaves the zip's folder ('..'); each must stay within it")
    if any(p in ("", ".") for p in parts):
        raise UploadRefused(f"{shown}: an empty or '.' part; give each folder by its name")
    if len(parts) > MAX_DEPTH:
        raise UploadRefused(f"{shown}: {len(parts)} levels deep; a zip may nest {MAX_DEPTH}")
    if info.flag_bits & 0x1:
        raise UploadRefused(f"{shown} is encrypted; give the zip without a password")
    mode = info.external_attr >> 16
    if stat.S_ISLNK(mode):
        raise UploadRefused(f"{shown} is a link; a robot's zip holds plain files and folders only")
    if stat.S_IFMT(mode) not in (0, stat.S_IFREG, stat.S_IFDIR):
        raise UploadRefused(f"{shown} is no plain file; a robot's zip holds files and folders only")
    return "/".join(parts)


def _checked_xml(member: str, data: bytes) -> ElementTree.Element:
    """The XML file's root, its file references checked (each .xml or .urdf of an upload)."""
    try:
        data.decode("utf-8")  # what MuJoCo reads; a UTF-16 file could hide a DTD from the check
    except UnicodeDecodeError:
        raise UploadRefused(f"{member} is no UTF-8 text; a robot file is UTF-8 XML") from None
    if re.search(rb"<!\s*(DOCTYPE|ENTITY)", data, re.IGNORECASE):
        raise UploadRefused(
            f"{member} has a DTD or an entity (<!DOCTYPE or <!ENTITY): a robot file needs none, "
            "and an entity can name a file outside the upload"
        )
    try:
        root = ElementTree.fromstring(data)
    except ElementTree.ParseError as err:  # MuJoCo might read it, unchecked: refused
        raise UploadRefused(f"{member} is no XML: {err}") from None
    for include in root.iter("include"):  # its references are checked only in a file read here
        if not include.get("file", "").lower().endswith(".xml"):
            raise UploadRefused(
                f"{member}: <include file={include.get('file', '')!r:.80}>: an upload includes "
                ".xml files only"
            )
    base = posixpath.dirname(member)
    dirs = {""} | {v for e in root.iter() for k, v in e.attrib.items() if k in DIR_ATTRIBUTES}
    for element in root.iter():
        for key, value in element.attrib.items():
            if key in ("file", "filename") or key.startswith("file") or key in DIR_ATTRIBUTES:
                under = dirs if key not in DIR_ATTRIBUTES else {""}
                _check_reference(member, element.tag, key, value, base, under)
    return root


def _check_reference(
    member: str, tag: str, key: str, value: str, base: str, dirs: set[str]
) -> None:
    said = f"{member}: <{tag} {key}={value!r:.80}>"
    path = value
    if value.startswith("package://"):
        path = "/".join(value.removeprefix("package://").split("/")[1:])  # as read beside it
    elif "://" in value or value.startswith("file:"):
        raise UploadRefused(
            f"{said}: a file is named relative to the robot file (or package://) in an upload"
        )
    if path.startswith(("/", "\\")) or re.match(r"^[A-Za-z]:", path):
        raise UploadRefused(f"{said} is an absolute name; an upload names its files relative to it")
    for folder in dirs:
        joined = posixpath.normpath(posixpath.join(base, folder, path.replace("\\", "/")))
        if joined == ".." or joined.startswith("../") or joined.startswith("/"):
            raise UploadRefused(f"{said} leaves the upload's folder; its files must lie within it")


def _robot_file(
    name: str,
    files: dict[str, bytes],
    roots: dict[str, str],
    includes: set[str],
    chosen: str | None,
) -> str:
    if chosen is not None:
        chosen = chosen.strip("/")
        if chosen not in files:
            raise UploadRefused(f"file={chosen!r:.80} is not in {name}")
        if roots.get(chosen) not in ROBOT_ROOTS:
            raise UploadRefused(
                f"{chosen} is no URDF (<robot>) or MJCF (<mujoco>) file"
                + (f": its root element is <{roots[chosen]}>" if chosen in roots else "")
            )
        return chosen
    robots = [m for m, tag in roots.items() if tag in ROBOT_ROOTS and m not in includes]
    if not robots:
        held = ", ".join(list(files)[:8]) + (" …" if len(files) > 8 else "")
        raise UploadRefused(
            f"{name} holds no URDF (<robot>) or MJCF (<mujoco>) file ({held or 'nothing'})"
        )
    depth = min(m.count("/") for m in robots)
    top = [m for m in robots if m.count("/") == depth]
    if len(top) > 1:
        raise UploadRefused(
            f"{name} holds {len(top)} robot files ({', '.join(top[:6])}): zip one, or name it "
            "with file="
        )
    return top[0]


def _write(files: dict[str, bytes], folder: Path, robot: str) -> Unpacked:
    folder.mkdir(parents=True)
    try:
        inside = folder.resolve()
        for member, data in files.items():
            target = folder / member
            if not target.resolve().is_relative_to(inside):  # the names were checked: never
                raise UploadRefused(f"{member!r:.80} leaves the upload's folder")
            target.parent.mkdir(parents=True, exist_ok=True)
            with open(target, "xb") as out:
                out.write(data)
    except BaseException:
        shutil.rmtree(folder, ignore_errors=True)
        raise
    return Unpacked(folder, folder / robot, len(files))
