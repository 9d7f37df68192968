"""An SSP package opened safely: an `.ssp` zip extracted into a cache folder of ours, or a folder.

The archive is checked before a byte is written: every member's name is a relative path that
stays inside the package (no '..', no absolute path, no drive, no link), the members are few
enough and their declared sizes within `MAX_UNPACKED_BYTES`; while extracting, a member that
inflates beyond its declared size is stopped. The extraction goes to
`$TWMR_CACHE_DIR/ssp/<sha256 of the archive>` (written under a temporary name, then renamed), so
nothing lands beside the archive or in the results folder, and a package is unpacked once. The
folder's `.complete` holds the SHA-256 of every file written; a folder whose files differ from it
(edited, added, removed after the unpacking) is not trusted: it is unpacked again, with a
warning naming the file."""
from __future__ import annotations

import hashlib
import json
import logging
import os
import shutil
import stat
import tempfile
import zipfile
import zlib
from pathlib import Path, PurePosixPath

from twmr.core.errors import Location, Problem, ScenarioError

#: the most bytes an archive may unpack to, and the most members it may hold
MAX_UNPACKED_BYTES = 4 * 2**30
MAX_MEMBERS = 10_000
_CHUNK = 2**20
#: the file of an unpacked folder that marks it complete and records its files' SHA-256
MANIFEST = ".complete"

log = logging.getLogger(__name__)


def cache_root() -> Path:
    """Where packages are unpacked: `$TWMR_CACHE_DIR/ssp` (default ~/.cache/twmr/ssp)."""
    env = os.environ.get("TWMR_CACHE_DIR")
    base = Path(env) if env else Path(os.environ.get("XDG_CACHE_HOME") or
                                      Path.home() / ".cache") / "twmr"
    return base / "ssp"


def unpacked(archive: Path) -> Path:
    """The folder holding the checked contents of the `.ssp` zip `archive`."""
    source = str(archive)
    if not zipfile.is_zipfile(archive):
        raise ScenarioError(Problem(Location(source), "the file is not a zip archive, so not an "
                                    "SSP package.", "give an .ssp file (a zip holding "
                                    "SystemStructure.ssd), or the unpacked folder."))
    digest = hashlib.sha256()
    with archive.open("rb") as f:
        for chunk in iter(lambda: f.read(_CHUNK), b""):
            digest.update(chunk)
    target = cache_root() / digest.hexdigest()[:32]
    if (target / MANIFEST).is_file():
        changed = _changed(target)
        if not changed:
            return target
        log.warning("the unpacked copy of %s in %s was changed since it was unpacked (%s); "
                    "unpacking it again", source, target, changed)
        shutil.rmtree(target, ignore_errors=True)
    target.parent.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix=".partial-", dir=target.parent))
    try:
        try:
            with zipfile.ZipFile(archive) as z:
                for info, rel in _checked(z, source):
                    _extract(z, info, work / rel, source)
        except (zipfile.BadZipFile, zlib.error, EOFError, NotImplementedError) as err:
            raise _refused(source, f"it is damaged or uses a feature zipfile cannot read "
                           f"({err})", "repack the archive (plain zip, deflate).") from None
        _verify(work, source)
        (work / MANIFEST).write_text(json.dumps({"archive": source, "files": _digests(work)},
                                                indent=1, sort_keys=True) + "\n")
        if target.exists() and not (target / MANIFEST).is_file():  # left by a killed run
            shutil.rmtree(target, ignore_errors=True)
        try:
            work.rename(target)
        except OSError:  # another process unpacked it first
            if not (target / MANIFEST).is_file():
                raise
    finally:
        if work.exists():
            shutil.rmtree(work, ignore_errors=True)
    return target


def _digests(folder: Path) -> dict[str, str]:
    """SHA-256 of every file under `folder` but the manifest, by relative POSIX path."""
    out = {}
    for path in sorted(folder.rglob("*")):
        if path.is_file() and path.name != MANIFEST:
            digest = hashlib.sha256()
            with path.open("rb") as f:
                for chunk in iter(lambda: f.read(_CHUNK), b""):
                    digest.update(chunk)
            out[path.relative_to(folder).as_posix()] = digest.hexdigest()
    return out


def _changed(folder: Path) -> str:
    """'' when the files under `folder` are those its manifest records, else the first that
    differs (or why the manifest cannot be read)."""
    try:
        recorded = json.loads((folder / MANIFEST).read_text())["files"]
    except (OSError, ValueError, KeyError, TypeError):
        return f"its {MANIFEST} is not one twmr wrote"
    now = _digests(folder)
    for name in sorted(set(recorded) | set(now)):
        if recorded.get(name) != now.get(name):
            what = "added" if name not in recorded else "removed" if name not in now else \
                "edited"
            return f"'{name}' {what}"
    return ""


def _checked(z: zipfile.ZipFile, source: str) -> list[tuple[zipfile.ZipInfo, PurePosixPath]]:
    """The archive's file members with their safe relative paths; ScenarioError otherwise."""
    infos = z.infolist()
    if len(infos) > MAX_MEMBERS:
        raise _refused(source, f"it holds {len(infos):,} members, more than the limit of "
                       f"{MAX_MEMBERS:,}", "an SSP package holds a description and its FMUs; "
                       "check that this is the right file.")
    total = 0
    members = []
    for info in infos:
        name = info.filename
        rel = PurePosixPath(name.replace("\\", "/"))
        if rel.is_absolute() or ".." in rel.parts or (rel.parts and ":" in rel.parts[0]) \
                or name.startswith(("/", "\\")):
            raise _refused(source, f"the member '{name}' points outside the package (an "
                           f"absolute path or '..': a zip-slip attempt)",
                           "repack the archive with paths relative to its root.")
        mode = info.external_attr >> 16
        if stat.S_ISLNK(mode):
            raise _refused(source, f"the member '{name}' is a symbolic link",
                           "repack the archive with the files themselves.")
        if info.is_dir():
            continue
        total += info.file_size
        if total > MAX_UNPACKED_BYTES:
            raise _refused(source, f"it unpacks to more than {MAX_UNPACKED_BYTES:,} bytes",
                           "check that this is the right file (a zip bomb is refused).")
        members.append((info, rel))
    return members


def _extract(z: zipfile.ZipFile, info: zipfile.ZipInfo, dest: Path, source: str) -> None:
    dest.parent.mkdir(parents=True, exist_ok=True)
    written = 0
    with z.open(info) as src, dest.open("wb") as out:
        for chunk in iter(lambda: src.read(_CHUNK), b""):
            written += len(chunk)
            if written > info.file_size:
                raise _refused(source, f"the member '{info.filename}' inflates beyond the "
                               f"{info.file_size:,} bytes its header declares",
                               "repack the archive (a zip bomb is refused).")
            out.write(chunk)


def _verify(folder: Path, source: str) -> None:
    """Every path written lies inside `folder`."""
    root = folder.resolve()
    for path in folder.rglob("*"):
        if path.is_symlink() or not path.resolve().is_relative_to(root):
            raise _refused(source, f"'{path.relative_to(folder)}' resolves outside the package",
                           "repack the archive with plain relative paths.")


def _refused(source: str, why: str, fix: str) -> ScenarioError:
    return ScenarioError(Problem(Location(source), f"the SSP archive is refused: {why}.", fix))
