"""Writing files so that nothing is ever half-written: the one place for it.

`write_whole` writes beside the target and renames into place, so a reader (or a crash) sees the old file
or the new one, never a part. `check_writable` tries the only sure test of writability (a probe file),
since permission bits lie to root (/proc/self looks writable) and /dev/null is not a folder.
"""

from __future__ import annotations

import os
import stat
import tempfile
from pathlib import Path

from attribot.errors import InputError

__all__ = ["write_whole", "check_writable", "check_regular_file", "not_a_file"]


def write_whole(path: Path, data: bytes) -> None:
    """Write `data` to `path` whole: to a temporary file in the same folder, then renamed into place."""
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
    except OSError as exc:
        return f"unreadable ({exc.strerror or exc})"
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


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
