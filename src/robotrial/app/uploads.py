"""Robots that users upload through the page (layer 5): a URDF zip with its meshes, a
xacro file, or an RDTF (.glb) file becomes a RobotModel the server can show.

Every upload gets a folder of its own inside the server's uploads folder. Zip entries
are written only inside that folder: an entry whose name climbs out of it (`../x`, an
absolute path, a drive letter) or that is a symbolic link is refused before anything is
written. Sizes are bounded: the upload itself (`max_bytes`), and what a zip unpacks to
(`max_unpacked_bytes`, `max_entries`), so a small zip cannot fill the disk; the triangles
of its mesh files (`max_triangles`, counted from their headers before any is read), so a
small zip cannot fill the memory. The robot is loaded confined to its folder: it cannot
read the server's environment or files (model/xacro.py). A refused upload leaves
nothing behind: its folder and its cached meshes go.
"""

from __future__ import annotations

import itertools
import re
import shutil
import stat
import threading
import zipfile
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from robotrial.model import load_robot
from robotrial.model.meshes import MESH_SUFFIXES, forget, triangle_count
from robotrial.model.rdtf import write_rdtf
from robotrial.model.robot import ModelError, RobotModel

MAX_UPLOAD_BYTES = 50 * 1024 * 1024
MAX_UNPACKED_BYTES = 200 * 1024 * 1024
MAX_ZIP_ENTRIES = 2000
MAX_TRIANGLES = 1_000_000  # of all mesh files in one upload; a corpus robot has at most 0.5 M
ROBOT_FILE_SUFFIXES = (".urdf", ".xacro", ".glb")
UPLOAD_SUFFIXES = (".zip", *ROBOT_FILE_SUFFIXES)


class UploadRefused(ValueError):
    """An upload that cannot be accepted; the message says why and what to send instead.
    `status` is the HTTP status that fits (400 bad input, 413 too large)."""

    def __init__(self, message: str, status: int = 400) -> None:
        super().__init__(message)
        self.status = status


@dataclass(frozen=True)
class UploadedRobot:
    """A robot loaded from an upload: its catalog name, model and where its files are."""

    name: str
    model: RobotModel
    rdtf: bytes
    folder: Path
    source: str


def too_large_message(limit: int) -> str:
    return (
        f"the upload is larger than {limit / 2**20:.3g} MB, the most this server takes; "
        "leave out what the robot does not need (textures, source files) or shrink its meshes"
    )


def safe_name(text: str) -> str:
    """A catalog name from free text: lower case letters, digits and underscores."""
    name = re.sub(r"[^a-z0-9_]+", "_", text.lower()).strip("_")
    return name or "robot"


def unique_name(text: str, taken: set[str]) -> str:
    """A list name from free text (`safe_name`) that is not in `taken`: a number is
    added when it is."""
    base = safe_name(text)
    name = base
    for i in itertools.count(2):
        if name not in taken:
            break
        name = f"{base}_{i}"
    return name


def stored_name(filename: str) -> str:
    """The name an upload is saved under in its folder: the sent file's base name with
    anything but letters, digits, dots, dashes and underscores replaced."""
    name = PurePosixPath(filename.replace("\\", "/")).name
    return re.sub(r"[^A-Za-z0-9._-]+", "_", name).lstrip(".") or "upload"


def robot_stem(filename: str) -> str:
    """The file name without its robot suffixes (`arm.urdf.xacro` -> `arm`)."""
    name = PurePosixPath(filename.replace("\\", "/")).name
    for suffix in (".zip", ".glb", ".xacro", ".urdf"):
        if name.lower().endswith(suffix):
            name = name[: -len(suffix)]
    return name


class UploadStore:
    """The uploads folder of one server and the robots loaded from it. Thread-safe."""

    def __init__(
        self,
        root: Path,
        max_bytes: int = MAX_UPLOAD_BYTES,
        max_unpacked_bytes: int = MAX_UNPACKED_BYTES,
        max_entries: int = MAX_ZIP_ENTRIES,
        max_triangles: int = MAX_TRIANGLES,
    ) -> None:
        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=True)
        self.max_bytes = max_bytes
        self.max_unpacked_bytes = max_unpacked_bytes
        self.max_entries = max_entries
        self.max_triangles = max_triangles
        self._lock = threading.Lock()
        self._counter = itertools.count(1)

    def new_folder(self, filename: str) -> Path:
        """An empty folder for one upload, named after its number and file."""
        with self._lock:
            number = next(self._counter)
        folder = self.root / f"{number:04d}-{safe_name(robot_stem(filename))}"
        folder.mkdir(parents=True)
        return folder

    def load(self, filename: str, data_path: Path, taken: set[str]) -> UploadedRobot:
        """Unpack (zips) and load the upload at `data_path`, sent as `filename`; its name
        in the catalog avoids `taken`. Raises UploadRefused or ModelError (the message
        names the file inside the upload, not the server's folders)."""
        lower = filename.lower()
        if not lower.endswith(UPLOAD_SUFFIXES):
            raise UploadRefused(
                f"{filename!r} is not a robot file: send a .zip (a URDF or xacro with its "
                "meshes), a .urdf, a .xacro or an RDTF .glb"
            )
        folder = data_path.parent
        try:
            if lower.endswith(".zip"):
                self._unpack(filename, data_path, folder)
                data_path.unlink()
                robot_file = find_robot_file(filename, folder)
            else:
                robot_file = data_path
            self._check_triangles(filename, folder)
            try:
                model = load_robot(robot_file, package_paths=[folder], confined=folder)
                rdtf = write_rdtf(model)
            except ModelError as exc:
                raise ModelError(_relative(str(exc), folder, filename)) from None
            except (OSError, ValueError, KeyError) as exc:
                where = _relative(str(robot_file), folder, filename)
                raise ModelError(f"{where}: {_relative(str(exc), folder, filename)}") from None
        except BaseException:
            forget(folder)
            shutil.rmtree(folder, ignore_errors=True)
            raise
        name = unique_name(model.name or robot_stem(filename), taken)
        return UploadedRobot(name, model, rdtf, folder, filename)

    def _check_triangles(self, filename: str, folder: Path) -> None:
        """Refuse an upload whose mesh files hold more than `max_triangles` triangles,
        naming the largest files and their counts."""
        counts = sorted(
            (
                (triangle_count(p), str(p.relative_to(folder)))
                for p in folder.rglob("*")
                if p.suffix.lower() in MESH_SUFFIXES and p.is_file()
            ),
            reverse=True,
        )
        total = sum(n for n, _ in counts)
        if total > self.max_triangles:
            largest = ", ".join(f"{name} ({n:,} triangles)" for n, name in counts[:3] if n)
            raise UploadRefused(
                f"{filename}: its meshes hold {total:,} triangles; at most "
                f"{self.max_triangles:,} are taken. Largest: {largest}. Simplify them "
                "(e.g. Blender's Decimate) or leave out meshes the robot does not use",
                status=413,
            )

    def _unpack(self, filename: str, path: Path, folder: Path) -> None:
        try:
            archive = zipfile.ZipFile(path)
        except zipfile.BadZipFile:
            raise UploadRefused(f"{filename}: not a readable zip file") from None
        with archive:
            infos = archive.infolist()
            if len(infos) > self.max_entries:
                raise UploadRefused(
                    f"{filename}: {len(infos)} entries; at most {self.max_entries} are taken"
                )
            total = sum(i.file_size for i in infos)
            if total > self.max_unpacked_bytes:
                raise UploadRefused(
                    f"{filename}: unpacks to {total / 2**20:.0f} MB; at most "
                    f"{self.max_unpacked_bytes // 2**20} MB are taken",
                    status=413,
                )
            base = folder.resolve()
            for info in infos:
                target = entry_target(base, info.filename)
                if target is None:
                    raise UploadRefused(
                        f"{filename}: entry {info.filename!r} would be written outside its "
                        "folder; refused (zip entries must be relative paths without '..')"
                    )
                if stat.S_ISLNK(info.external_attr >> 16):
                    raise UploadRefused(
                        f"{filename}: entry {info.filename!r} is a symbolic link; refused"
                    )
            for info in infos:
                target = entry_target(base, info.filename)
                assert target is not None
                if info.is_dir():
                    target.mkdir(parents=True, exist_ok=True)
                    continue
                target.parent.mkdir(parents=True, exist_ok=True)
                with archive.open(info) as src, open(target, "wb") as dst:
                    shutil.copyfileobj(src, dst, 1 << 20)


def entry_target(base: Path, entry: str) -> Path | None:
    """Where zip entry `entry` goes under the resolved folder `base`, or None if its
    name would leave it (absolute, drive letter, '..' that climbs out)."""
    name = entry.replace("\\", "/")
    if name.startswith("/") or re.match(r"^[A-Za-z]:", name):
        return None
    target = (base / name).resolve()
    if target != base and base not in target.parents:
        return None
    return target


def find_robot_file(filename: str, folder: Path) -> Path:
    """The one URDF or xacro in an unpacked zip: the shallowest; at equal depth a
    `.urdf.xacro`/`.xacro` wins over a `.urdf` built from it only if no `.urdf` is there."""
    candidates = [
        p
        for p in folder.rglob("*")
        if p.is_file()
        and p.name.lower().endswith((".urdf", ".xacro"))
        and "__MACOSX" not in p.parts
    ]
    if not candidates:
        raise UploadRefused(
            f"{filename}: no .urdf or .xacro file inside; the zip must hold the robot's "
            "URDF (or xacro) and its meshes"
        )
    depth = min(len(p.relative_to(folder).parts) for p in candidates)
    top = sorted(p for p in candidates if len(p.relative_to(folder).parts) == depth)
    urdfs = [p for p in top if p.name.lower().endswith(".urdf")]
    chosen = urdfs or top
    if len(chosen) > 1:
        names = ", ".join(str(p.relative_to(folder)) for p in chosen)
        raise UploadRefused(
            f"{filename}: several robot files at the top ({names}); zip one robot at a time"
        )
    return chosen[0]


def _relative(text: str, folder: Path, filename: str) -> str:
    """`text` with the server's folder for this upload replaced by the upload's name."""
    inside = f"{filename}/" if filename.endswith(".zip") else ""
    for base in sorted({str(folder.resolve()), str(folder)}, key=len, reverse=True):
        text = text.replace(base + "/", inside).replace(base, filename)
    return text
