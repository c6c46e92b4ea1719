"""Where the files a robot description names actually are: `package://`, `file://`, paths.

Layer 1. A URDF names its meshes and textures as `package://NAME/rest`, `file:///abs`,
absolute or relative paths. ROS finds packages through its install space; robotrial
finds them through search paths, in this order:

1. the explicit `package_paths` given by the caller,
2. the folders of the `ROS_PACKAGE_PATH` environment variable (colon separated),
3. the folders above the description file.

A resolver `confined` to a folder (a description someone uploaded) searches only inside
it and refuses (ResourceRefused) what would leave it: absolute and `file://` paths,
`~`, relative paths that climb out, packages found outside. When a `package://` file
is not where the URI says, but the upload holds exactly one file whose path ends as the
URI's does (the longest such ending wins), the URI's leading folders are mapped to where
that file is (a zip packed one folder higher or lower than the URDF expects); the mapping
is kept for the next URIs and told in `remaps`. Messages of a confined resolver name
files as they are inside the upload, never the server's folders.

In each search folder a package NAME is the folder itself, a sub-folder, or (up to
`MAX_DEPTH` levels down) a descendant folder that is named NAME or holds a
`package.xml` whose `<name>` is NAME. For the folders above the file only the folder
itself and its direct sub-folders are looked at. When several candidates match, the
first that holds the requested file wins.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from urllib.parse import unquote

from robotrial.model.robot import ModelError

MAX_DEPTH = 3
_NAME_RE = re.compile(rb"<name>\s*([^<\s]+)\s*</name>")


class ResourceNotFound(ModelError):
    """A `package://`, `file://` or relative reference that names no existing file."""

    def __init__(self, uri: str, searched: Sequence[str]) -> None:
        self.uri = uri
        self.searched = tuple(searched)
        where = "; ".join(self.searched) if self.searched else "nowhere"
        super().__init__(f"cannot find {uri!r} (searched: {where})")


class ResourceRefused(ModelError):
    """A reference a confined description may not follow; `reason` says why."""

    def __init__(self, uri: str, reason: str) -> None:
        self.uri = uri
        self.reason = reason
        super().__init__(f"{uri!r} refused: {reason}")


@lru_cache(maxsize=4096)
def _package_xml_name(folder: Path) -> str:
    """The `<name>` in folder/package.xml, or "" when there is none."""
    try:
        data = (folder / "package.xml").read_bytes()
    except OSError:
        return ""
    m = _NAME_RE.search(data)
    return m.group(1).decode("utf-8", "replace") if m else ""


def _is_package(folder: Path, name: str) -> bool:
    return folder.name == name or _package_xml_name(folder) == name


def _subdirs(folder: Path) -> list[Path]:
    try:
        return sorted(p for p in folder.iterdir() if p.is_dir() and not p.name.startswith("."))
    except OSError:
        return []


def _walk_packages(root: Path, name: str, depth: int) -> Iterator[Path]:
    """Folders at or below `root` (up to `depth` levels) that are package `name`."""
    if _is_package(root, name):
        yield root
    if depth <= 0:
        return
    for sub in _subdirs(root):
        yield from _walk_packages(sub, name, depth - 1)


def _env_package_paths() -> list[Path]:
    raw = os.environ.get("ROS_PACKAGE_PATH", "")
    return [Path(p) for p in raw.split(os.pathsep) if p.strip()]


@dataclass(frozen=True)
class PackageResolver:
    """Turns the URIs of one description file into absolute paths.

    `base_dir` is the folder of the description file (relative paths start there and
    its ancestors are searched for packages); `package_paths` are searched first.
    """

    base_dir: Path | None = None
    package_paths: tuple[Path, ...] = ()
    use_environment: bool = True
    confined: Path | None = None
    _cache: dict[str, list[Path]] = field(default_factory=dict, compare=False, repr=False)
    remaps: dict[tuple[str, ...], Path] = field(default_factory=dict, compare=False, repr=False)
    """URI folders (package name first) mapped to folders of the upload, as found."""
    _files: list[tuple[str, ...]] = field(default_factory=list, compare=False, repr=False)

    @staticmethod
    def create(
        base_dir: str | Path | None,
        package_paths: Sequence[str | Path] = (),
        use_environment: bool = True,
        confined: str | Path | None = None,
    ) -> PackageResolver:
        """`confined`: the folder everything must stay in (no environment is read)."""
        base = Path(base_dir).resolve() if base_dir is not None else None
        paths = tuple(Path(p).expanduser().resolve() for p in package_paths)
        if confined is None:
            return PackageResolver(base, paths, use_environment)
        root = Path(confined).resolve()
        return PackageResolver(base, paths, False, root)

    def within(self, path: Path) -> bool:
        """Whether `path` (links followed) stays inside the confining folder (always
        True when not confined)."""
        if self.confined is None:
            return True
        real = path.resolve()
        return real == self.confined or self.confined in real.parents

    def search_roots(self) -> list[tuple[Path, int]]:
        """(folder, depth) pairs searched for packages, in order."""
        roots: list[tuple[Path, int]] = [(p, MAX_DEPTH) for p in self.package_paths]
        if self.use_environment:
            roots += [(p, MAX_DEPTH) for p in _env_package_paths()]
        if self.base_dir is not None:
            roots += [(a, 1) for a in (self.base_dir, *self.base_dir.parents)]
        return [(r, d) for r, d in roots if self.within(r)]

    def package_candidates(self, name: str) -> list[Path]:
        """Folders that are package `name`, best first."""
        if name in self._cache:
            return self._cache[name]
        found: list[Path] = []
        for root, depth in self.search_roots():
            if not root.is_dir():
                continue
            for p in _walk_packages(root, name, depth):
                if p not in found:
                    found.append(p)
        self._cache[name] = found
        return found

    def resolve(self, uri: str) -> Path:
        """The absolute path of an existing file named by `uri`; ResourceNotFound if none."""
        uri = uri.strip()
        if uri.startswith("package://"):
            rest = uri[len("package://") :].lstrip("/")
            name, _, sub = rest.partition("/")
            if not name or not sub:
                raise ResourceNotFound(uri, ["(malformed: expected package://NAME/path)"])
            candidates = self.package_candidates(name)
            for pkg in candidates:
                path = pkg / unquote(sub)
                if path.is_file():
                    if not self.within(path):
                        raise ResourceRefused(uri, "it leads outside the uploaded files")
                    return path.resolve()
            if self.confined is not None:
                found = self._remapped([name, *unquote(sub).split("/")])
                if isinstance(found, Path):
                    return found
                raise ResourceNotFound(uri, [self._missing_in_upload(name, sub, candidates, found)])
            searched = [str(p / sub) for p in candidates]
            if not candidates:
                searched = [
                    f"package {name!r} not found in {root}" for root, _ in self.search_roots()
                ]
            raise ResourceNotFound(uri, searched)
        if self.confined is not None:
            return self._resolve_confined(uri)
        if uri.startswith("file://"):
            path = Path(unquote(uri[len("file://") :]))
            if not path.is_absolute() and self.base_dir is not None:
                path = self.base_dir / path
        elif "://" in uri:
            raise ResourceNotFound(uri, ["(unsupported scheme; use package://, file:// or a path)"])
        else:
            path = Path(uri).expanduser()
            if not path.is_absolute():
                if self.base_dir is None:
                    raise ResourceNotFound(uri, ["(relative path with no base folder)"])
                path = self.base_dir / path
        if path.is_file():
            return path.resolve()
        raise ResourceNotFound(uri, [str(path)])

    def shown(self, path: Path) -> str:
        """`path` as the user knows it: relative to the confining folder (else as is)."""
        if self.confined is None:
            return str(path)
        try:
            return str(path.resolve().relative_to(self.confined)) or "."
        except ValueError:
            return path.name

    def _upload_files(self) -> list[tuple[str, ...]]:
        """Every file of the confining folder, as path parts relative to it."""
        if not self._files and self.confined is not None:
            self._files.extend(
                p.relative_to(self.confined).parts
                for p in sorted(self.confined.rglob("*"))
                if p.is_file() and not p.is_symlink()
            )
        return self._files

    def _remapped(self, parts: list[str]) -> Path | list[tuple[str, ...]]:
        """The upload's file for `package://` path `parts` found by the mapping of a
        previous URI, else by the longest ending only one file of the upload has; else
        the files that share the longest ending (none, or several: ambiguous)."""
        assert self.confined is not None
        for prefix, folder in self.remaps.items():
            if tuple(parts[: len(prefix)]) == prefix:
                path = folder.joinpath(*parts[len(prefix) :])
                if path.is_file() and self.within(path):
                    return path.resolve()
        files = self._upload_files()
        for k in range(len(parts)):
            tail = tuple(parts[k:])
            matches = [f for f in files if f[-len(tail) :] == tail]
            if len(matches) > 1:
                return matches
            if matches:
                folder = self.confined.joinpath(*matches[0][: -len(tail)])
                path = folder.joinpath(*tail)
                if not self.within(path):
                    return []
                self.remaps[tuple(parts[:k])] = folder
                return path.resolve()
        return []

    def _missing_in_upload(
        self, name: str, sub: str, candidates: list[Path], alike: list[tuple[str, ...]]
    ) -> str:
        """Why a confined `package://NAME/sub` was not found, in the upload's terms."""
        if alike:
            shown = ", ".join("/".join(f) for f in alike[:4])
            return f"several files of the upload could be meant ({shown}); keep only one"
        if candidates:
            places = ", ".join(f"{self.shown(p)}/{sub}" for p in candidates)
            return f"the upload has package {name!r} but no file {places}"
        return (
            f"the upload has no folder {name!r} (a package folder, or one with a "
            f"package.xml naming it) and no file {sub.rsplit('/', 1)[-1]!r}"
        )

    def _resolve_confined(self, uri: str) -> Path:
        """A relative path inside the confining folder, or ResourceRefused."""
        if uri.startswith("file://") or "://" in uri:
            raise ResourceRefused(
                uri,
                "uploaded descriptions may name files only as "
                "package://NAME/path or a path relative to the file",
            )
        if uri.startswith(("/", "~", "\\")) or re.match(r"^[A-Za-z]:", uri):
            raise ResourceRefused(uri, "absolute paths are not allowed in uploaded descriptions")
        if self.base_dir is None:
            raise ResourceNotFound(uri, ["(relative path with no base folder)"])
        path = self.base_dir / unquote(uri)
        if not self.within(path):
            raise ResourceRefused(uri, "the path leads outside the uploaded files")
        if path.is_file():
            return path.resolve()
        raise ResourceNotFound(uri, [str(path.relative_to(self.base_dir))])


def resolve_uri(
    uri: str, base_dir: str | Path | None = None, package_paths: Sequence[str | Path] = ()
) -> Path:
    """One-shot resolution of `uri` (see PackageResolver)."""
    return PackageResolver.create(base_dir, package_paths).resolve(uri)


__all__ = ["PackageResolver", "ResourceNotFound", "ResourceRefused", "resolve_uri"]
