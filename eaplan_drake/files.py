"""Writing files whole or not at all, and strict JSON.

Every file a run writes goes through a temporary file in the same folder, ``fsync``, ``rename``
(:func:`AtomicWrite`); a result directory is written into a temporary directory that replaces
the old one as a unit (:func:`ResultDirectory`), so a new log never sits beside an old figure.
Temporary files are removed on every exit Python sees; those of a killed process (named with its
pid) by the next write into the same folder. :func:`StrictJson` writes NaN and infinities as
``null``.
"""

import contextlib
import json
import math
import os
import re
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

__all__ = [
    "AtomicWrite",
    "JsonSafe",
    "MissingFile",
    "ReadTextFile",
    "ResultDirectory",
    "StrictJson",
]


def StrictJson(value) -> str:
    """``value`` as strict JSON text (NaN and ±inf become ``null``, numpy scalars and arrays
    plain numbers and lists), indented, keys sorted."""
    return json.dumps(JsonSafe(value), indent=2, sort_keys=True, allow_nan=False) + "\n"


def _Umask() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return umask


def _FsyncDirectory(directory: Path) -> None:
    fd = os.open(directory, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


_TEMP = re.compile(r"\.(?P<name>.+)\.(?P<pid>\d+)\.[^.]+\.(tmp|old)")


def _RemoveStaleTemps(folder: Path) -> None:
    """Removes the temporary files and directories of killed processes in ``folder`` (named
    ``.<name>.<pid>.<random>.tmp`` or ``.old`` with a pid that no longer runs)."""
    with contextlib.suppress(OSError):
        for entry in folder.iterdir():
            m = _TEMP.fullmatch(entry.name)
            if not m or _PidAlive(int(m.group("pid"))):
                continue
            if entry.is_dir() and not entry.is_symlink():
                shutil.rmtree(entry, ignore_errors=True)
            else:
                entry.unlink(missing_ok=True)


def _PidAlive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # e.g. another user's process
        return True
    return True


def AtomicWrite(path: str | Path, write: Callable, binary: bool) -> Path:
    """Writes ``path`` whole or not at all: ``write(f)`` into a temporary file in the same
    folder, flush, ``fsync``, ``rename`` onto ``path``, ``fsync`` of the folder. The temporary
    file is removed on any exception (and by the next write into the folder if the process was
    killed). The file gets the normal mode (0666 & ~umask)."""
    path = Path(path)
    _RemoveStaleTemps(path.parent)
    fd, tmp = tempfile.mkstemp(
        dir=path.parent, prefix=f".{path.name}.{os.getpid()}.", suffix=".tmp"
    )
    try:
        with os.fdopen(fd, "wb" if binary else "w", encoding=None if binary else "utf-8") as f:
            write(f)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, 0o666 & ~_Umask())  # mkstemp makes 0600; the result is a normal file
        os.replace(tmp, path)
    except OSError as e:
        Path(tmp).unlink(missing_ok=True)
        if e.filename is None:  # a full disk says nothing of where: name the file
            raise OSError(e.errno, e.strerror or str(e), str(path)) from None
        raise
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    _FsyncDirectory(path.parent)
    return path


@contextlib.contextmanager
def ResultDirectory(directory: str | Path):
    """Context manager: yields a new empty temporary directory next to ``directory``; when the
    block ends without an exception it replaces ``directory`` as a whole (the old one, with
    everything in it, is removed), otherwise it is removed. A reader never sees a mix of old
    and new files; a kill between the two renames leaves no ``directory`` (and a hidden old copy
    that the next save removes)."""
    final = Path(directory)
    final.parent.mkdir(parents=True, exist_ok=True)
    _RemoveStaleTemps(final.parent)
    tmp = Path(
        tempfile.mkdtemp(dir=final.parent, prefix=f".{final.name}.{os.getpid()}.", suffix=".tmp")
    )
    try:
        yield tmp
        os.chmod(tmp, 0o777 & ~_Umask())
        _FsyncDirectory(tmp)
        if final.exists() or final.is_symlink():
            old = Path(f"{tmp}"[: -len(".tmp")] + ".old")
            os.replace(final, old)
            os.replace(tmp, final)
            _FsyncDirectory(final.parent)
            if old.is_dir() and not old.is_symlink():
                shutil.rmtree(old)
            else:
                old.unlink()
        else:
            os.replace(tmp, final)
        _FsyncDirectory(final.parent)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def JsonSafe(value):
    if isinstance(value, dict):
        return {str(k): JsonSafe(v) for k, v in value.items()}
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, list | tuple):
        return [JsonSafe(v) for v in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def MissingFile(path: Path, what: str = "file") -> str:
    """Why ``path`` is not a readable ``what`` ("no such file", "a folder, not a file"), or ""
    when it is a file: the one-line reason a command gives."""
    path = Path(path)
    if path.is_file():
        return ""
    if path.is_dir():
        return f"a folder, not a {what}"
    return f"no such {what}"


def ReadTextFile(path: Path, max_bytes: int, error: type) -> str:
    """The UTF-8 text of ``path``; ``error`` (one line naming the file) if it is larger than
    ``max_bytes``, unreadable or not UTF-8."""
    try:
        size = path.stat().st_size
        if size > max_bytes:
            raise error(f"{path}: {size} bytes, more than the {max_bytes} allowed")
        raw = path.read_bytes()
    except OSError as e:
        raise error(f"{path}: cannot read: {e.strerror or e}") from None
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as e:
        line = raw[: e.start].count(b"\n") + 1
        col = e.start - (raw.rfind(b"\n", 0, e.start) + 1) + 1
        raise error(f"{path}:{line}:{col}: not UTF-8 text (byte 0x{raw[e.start]:02x})") from None
