"""Atomic file writes: write a temporary file beside the target, then rename it."""

from __future__ import annotations

import os
import re
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

# the hidden temporary files atomic_path makes: ``.<target name>.<8 random characters>.tmp``
# (with the journal SQLite keeps beside one while writing it, and the USD writer's layer,
# which takes the target's suffix)
TEMP_NAME = re.compile(r"^\..+\.[a-z0-9_]{8}\.(tmp(-journal|-wal|-shm)?|usd|usda|usdc)$")


class WriteError(OSError):
    """A file that could not be written, named as the caller named it (never by the
    temporary file the write went to), with the system's reason."""

    def __str__(self) -> str:
        return str(self.strerror)


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path in the target's folder; rename it onto ``path`` on success.

    On any exception (an error, or Ctrl-C while writing) the temporary file is removed
    and ``path`` is left untouched: the file is either whole or as it was. An OSError
    from the write comes back as :class:`WriteError` naming ``path``. A temporary file
    left by a process killed outright matches :data:`TEMP_NAME` (see
    :func:`remove_stale_temps`).
    """
    path = Path(path)
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise FileNotFoundError(f"cannot write {path}: folder {folder} does not exist")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    except OSError as exc:
        raise WriteError(exc.errno, f"cannot write {path}: {exc.strerror or exc}") from None
    tmp_path = Path(tmp)
    done = False
    try:
        os.close(fd)
        yield tmp_path
        os.chmod(tmp_path, 0o666 & ~_umask())  # mkstemp makes 0600; give the file the usual mode
        os.replace(tmp_path, path)
        done = True
    except OSError as exc:
        reason = exc.strerror or str(exc).replace(str(tmp_path), str(path))
        raise WriteError(exc.errno, f"cannot write {path}: {reason}") from exc
    finally:
        if not done:  # an error or an interrupt: no temporary file stays behind
            for leftover in (tmp_path, *(Path(f"{tmp_path}{j}") for j in ("-journal", "-wal", "-shm"))):
                try:
                    leftover.unlink()
                except OSError:
                    pass


def remove_stale_temps(folder: str | Path) -> list[Path]:
    """Remove the temporary files that writes into ``folder`` left when their process
    was killed outright (``.<name>.<random>.tmp``); returns those removed. Only for a
    folder no other process is writing into (a run's locked output folder)."""
    folder = Path(folder)
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        if TEMP_NAME.match(entry.name) and entry.is_file(follow_symlinks=False):
            try:
                os.unlink(entry.path)
                removed.append(Path(entry.path))
            except FileNotFoundError:
                pass
    return removed


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask
