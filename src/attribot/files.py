"""Writing files so that nothing is ever half-written: the one place for it.

`write_whole` writes beside the target and renames into place, so a reader (or a crash) sees the old file
or the new one, never a part. `check_writable` tries the only sure test of writability (a probe file),
since permission bits lie to root (/proc/self looks writable) and /dev/null is not a folder.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from attribot.errors import InputError

__all__ = ["write_whole", "check_writable"]


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


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
