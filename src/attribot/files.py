"""Files: written so that nothing is ever half-written, and read from outside within bounds. The one place
for both.

`write_whole` writes beside the target and renames into place, so a reader (or a crash) sees the old file
or the new one, never a part; it is the one way attribot writes a file, and it never writes through a link
nor replaces what is not a regular file (a device, a FIFO, a folder: `check_target`). `make_folder` makes
a folder attribot writes into, refusing one that is a link (a dataset's `shown` pointing elsewhere).
`check_writable` tries the only sure test of writability (a probe file),
since permission bits lie to root (/proc/self looks writable) and /dev/null is not a folder.

What comes from outside (a saved run, a run folder, a dataset, a settings file) is read as a stranger's
data: `inside` takes a file only inside the folder it belongs to (no absolute name, no `..`, no link that
leads out); `read_capped` reads only a regular file, and only when its size is within a stated bound,
checked before a byte is read; `read_json` and `parse_json` bound JSON in size and in depth.
`disk_full` names a write that failed for want of room, so that a command can say so and stop cleanly.
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import stat
import tempfile
from pathlib import Path, PurePosixPath
from typing import Any

from attribot.errors import InputError

__all__ = [
    "write_whole",
    "file_sha256",
    "check_target",
    "make_folder",
    "check_writable",
    "check_regular_file",
    "not_a_file",
    "inside",
    "read_capped",
    "read_json",
    "parse_json",
    "disk_full",
    "MAX_JSON_BYTES",
    "MAX_JSON_DEPTH",
]

MAX_JSON_BYTES = 1_000_000
"""The largest JSON file of settings or of a run's description read from outside (ours are a few kB)."""
MAX_JSON_DEPTH = 32
"""The deepest nesting of JSON read from outside (ours nest five deep)."""


_TARGET_FIX = "give a path where a regular file can be written (or remove what is there)"


def check_target(path: Path, what: str = "the file", fix: str = _TARGET_FIX) -> None:
    """Raise `InputError` unless `path` is absent or a regular file: a link (attribot writes through no link
    it did not make), a folder, a FIFO, a device or a socket is never replaced by a file."""
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        return
    except (OSError, ValueError) as exc:
        reason = getattr(exc, "strerror", None) or exc
        raise InputError(f"{what} {str(path)!r} cannot be looked at ({reason})", fix) from None
    if stat.S_ISLNK(mode):
        raise InputError(
            f"{what} {str(path)!r} is a link: attribot does not write through a link it did not make", fix
        )
    kind = _kind(mode)
    if kind is not None:
        raise InputError(f"{what} {str(path)!r} is {kind}, not a regular file: it is not replaced", fix)


def make_folder(path: Path, what: str = "the folder", fix: str = _TARGET_FIX) -> Path:
    """Make the folder `path` (and its parents) for attribot to write into; an `InputError` when it is a
    link (which would lead the writes elsewhere) or something other than a folder."""
    try:
        mode = os.lstat(path).st_mode
    except FileNotFoundError:
        mode = None
    except (OSError, ValueError) as exc:
        reason = getattr(exc, "strerror", None) or exc
        raise InputError(f"{what} {str(path)!r} cannot be looked at ({reason})", fix) from None
    if mode is not None and stat.S_ISLNK(mode):
        raise InputError(
            f"{what} {str(path)!r} is a link: attribot does not write through a link it did not make", fix
        )
    if mode is not None and not stat.S_ISDIR(mode):
        raise InputError(
            f"{what} {str(path)!r} is {_kind(mode) or 'a file'}, not a folder", f"check that path; {fix}"
        )
    if mode is None:
        try:
            path.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise InputError(f"{what} {str(path)!r} cannot be made ({exc.strerror or exc})", fix) from None
    return path


def write_whole(path: Path, data: bytes, what: str = "the file", fix: str = _TARGET_FIX) -> None:
    """Write `data` to `path` whole: to a temporary file in the same folder, then renamed into place. What
    is at `path` must be a regular file or nothing (`check_target`: never a link, a device, a FIFO)."""
    check_target(path, what, fix)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes it private; a saved answer is an ordinary file
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def check_writable(folder: Path, what: str, fix: str) -> None:
    """Raise `InputError` ("`what` cannot be written: ...") unless a file can be created in `folder`."""
    try:
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".attribot-probe-"):
            pass
    except OSError as exc:
        raise InputError(
            f"{what} cannot be written: {exc.strerror or exc.__class__.__name__} in {str(folder)!r}", fix
        ) from None


def not_a_file(path: Path) -> str | None:
    """None when `path` is a regular file (or a link to one); else what it is instead: "missing", "a
    folder", "a FIFO (named pipe)", "a device", "a socket", or why it cannot be looked at."""
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        return "missing"
    except (OSError, ValueError) as exc:  # ValueError: a NUL byte in the name
        return f"unreadable ({getattr(exc, 'strerror', None) or exc})"
    return _kind(mode)


def _kind(mode: int) -> str | None:
    """None for a regular file; else what `mode` says the file is."""
    if stat.S_ISREG(mode):
        return None
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    return "a socket" if stat.S_ISSOCK(mode) else "not a file"


def check_regular_file(path: Path, what: str, fix: str) -> None:
    """Raise `InputError` unless `path` is a regular file (or a link to one): a missing path, a folder, a
    FIFO (which would block a reader forever) or a device (/dev/zero, which never ends) each say which."""
    kind = not_a_file(path)
    if kind is None:
        return
    if kind == "missing":
        raise InputError(f"{what} {str(path)!r} does not exist", fix)
    if kind.startswith("unreadable"):
        raise InputError(f"{what} {str(path)!r} cannot be read: it is {kind}", fix)
    raise InputError(f"{what} {str(path)!r} is {kind}, not a regular file", fix)


def inside(folder: Path, name: object, what: str, fix: str) -> Path:
    """The file `name` of `folder`, resolved; an `InputError` unless it lies inside the folder: a name that is
    not text, absolute, climbs out with `..`, or a link (anywhere on the way) that leads out."""
    if not isinstance(name, str) or not name.strip() or "\x00" in name:
        raise InputError(f"{what} {name!r} is not the name of a file in {str(folder)!r}", fix)
    relative = PurePosixPath(name)
    if relative.is_absolute() or ".." in relative.parts:
        raise InputError(f"{what} {name!r} points outside {str(folder)!r}: only its own files are read", fix)
    try:
        base = folder.resolve()
        path = (base / relative).resolve()
    except (OSError, RuntimeError) as exc:  # a loop of links
        raise InputError(f"{what} {name!r} in {str(folder)!r} cannot be resolved ({exc})", fix) from None
    if not path.is_relative_to(base):
        raise InputError(
            f"{what} {name!r} is a link that leads outside {str(folder)!r}: only its own files are read", fix
        )
    return path


def read_capped(path: Path, what: str, max_bytes: int, fix: str) -> bytes:
    """The bytes of the regular file `path`; an `InputError` naming `what` when it is missing, not a regular
    file (a FIFO would block, /dev/zero never ends) or larger than `max_bytes`, said from its size before
    anything is read (and again if it grows while it is read)."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)  # a FIFO opens without waiting
    except FileNotFoundError:
        raise InputError(f"{what} {str(path)!r} does not exist", fix) from None
    except (OSError, ValueError) as exc:
        reason = getattr(exc, "strerror", None) or exc
        raise InputError(f"{what} {str(path)!r} cannot be read ({reason})", fix) from None
    try:
        info = os.fstat(fd)
        kind = _kind(info.st_mode)
        if kind is not None:
            raise InputError(f"{what} {str(path)!r} is {kind}, not a regular file", fix)
        if info.st_size > max_bytes:
            raise InputError(
                f"{what} {str(path)!r} holds {info.st_size:,} bytes, more than the {max_bytes:,} allowed", fix
            )
        chunks, size = [], 0
        while size <= max_bytes:
            chunk = os.read(fd, min(1 << 20, max_bytes + 1 - size))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
    except OSError as exc:
        raise InputError(f"{what} {str(path)!r} cannot be read ({exc.strerror or exc})", fix) from None
    finally:
        os.close(fd)
    if size > max_bytes:
        raise InputError(f"{what} {str(path)!r} grew past the {max_bytes:,} bytes it may hold", fix)
    return b"".join(chunks)


def parse_json(data: bytes | str, what: str, fix: str, max_depth: int = MAX_JSON_DEPTH) -> Any:
    """JSON text from outside, as data; an `InputError` naming `what` when it is not UTF-8 JSON or nests
    deeper than `max_depth`."""
    try:
        text = data.decode("utf-8") if isinstance(data, bytes) else data
        value = json.loads(text)
    except UnicodeDecodeError as exc:
        raise InputError(f"{what} is not UTF-8 text (byte {exc.start})", fix) from None
    except RecursionError:
        raise InputError(f"{what} nests deeper than the {max_depth} levels allowed", fix) from None
    except ValueError as exc:
        raise InputError(f"{what} is not valid JSON ({exc})", fix) from None
    if _depth(value, max_depth) > max_depth:
        raise InputError(f"{what} nests deeper than the {max_depth} levels allowed", fix)
    return value


def read_json(
    path: Path, what: str, fix: str, max_bytes: int = MAX_JSON_BYTES, max_depth: int = MAX_JSON_DEPTH
) -> Any:
    """The JSON file `path` from outside, as data: `read_capped`, then `parse_json`."""
    return parse_json(read_capped(path, what, max_bytes, fix), f"{what} {str(path)!r}", fix, max_depth)


def _depth(value: Any, limit: int) -> int:
    """How deep `value` nests (lists and dicts), counting no further than `limit` + 1."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        item, depth = stack.pop()
        if not isinstance(item, list | dict):
            continue
        deepest = max(deepest, depth)
        if depth > limit:
            return depth
        stack.extend((v, depth + 1) for v in (item.values() if isinstance(item, dict) else item))
    return deepest


_NO_ROOM = {errno.ENOSPC, errno.EDQUOT, errno.EFBIG}


def disk_full(exc: BaseException) -> bool:
    """Whether `exc` is a write that failed for want of room: the disk or the quota full, a file too large."""
    return isinstance(exc, OSError) and exc.errno in _NO_ROOM


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def file_sha256(path: Path) -> str:
    """The SHA-256 of the file at `path`, read in 1 MiB blocks (weights files are tens of MB)."""
    digest = hashlib.sha256()
    with path.open("rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()
