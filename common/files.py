"""The one way tribench writes a whole file: atomically, so a reader, a full disk or a kill never leaves a
truncated one; a failure to write is the environment's, a UserError naming the file.

>>> import tempfile, pathlib
>>> folder = pathlib.Path(tempfile.mkdtemp())
>>> write_text(folder / "a.txt", "hello\\n")
>>> (folder / "a.txt").read_text()
'hello\\n'
>>> with atomic_write(folder / "b.csv") as f:
...     _ = f.write("x,y\\n1,2\\n")
>>> sorted(p.name for p in folder.iterdir())
['a.txt', 'b.csv']
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import secrets
import stat
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any

from .errors import UserError

__all__ = ["atomic_write", "file_sha256", "read_user_text", "write_bytes", "write_text"]


@contextmanager
def atomic_write(path: str | Path, mode: str = "w") -> Iterator[IO[Any]]:
    """Open a temporary file beside ``path``; on a clean exit, flush it and rename it over ``path``.

    ``mode`` is ``"w"`` (UTF-8 text, ``"\\n"`` line ends) or ``"wb"``. The parent folder is created, and the file
    gets ``open``'s permissions (``0o666`` less the umask), not ``mkstemp``'s ``0o600``. If the body raises
    (Ctrl-C included) or the write fails, ``path`` is left as it was; an ``OSError`` becomes a ``UserError``."""
    if mode not in ("w", "wb"):
        raise ValueError(f"mode must be 'w' or 'wb', got {mode!r}")
    path = Path(path)
    tmp: str | None = None
    for folder in (path.parent, *path.parent.parents):
        if folder.exists() and not folder.is_dir():
            raise UserError(f"cannot write {path}: {folder} is a file, not a folder")
    # the rename would put a regular file in place of a device, a folder or a link
    # (as root, `--out /dev/null` would replace the device): only regular files are replaced
    if os.path.lexists(path) and not stat.S_ISREG(os.lstat(path).st_mode):
        raise UserError(
            f"cannot write {path}: it exists and is not a regular file (a folder, a device or a link); "
            f"choose another path"
        )
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        # a unique name in the same folder (same file system, so the rename is atomic)
        name = str(path.parent / f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp")
        fd = os.open(name, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        tmp = name
        text = mode == "w"
        with os.fdopen(fd, mode, encoding="utf-8" if text else None, newline="" if text else None) as f:
            yield f
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
        tmp = None
    except OSError as exc:
        raise UserError(f"cannot write {path}: {exc.strerror or exc}") from exc
    finally:
        if tmp is not None:
            with contextlib.suppress(OSError):
                os.unlink(tmp)


def write_text(path: str | Path, text: str) -> None:
    """Write ``text`` to ``path`` atomically, in UTF-8 (see :func:`atomic_write`)."""
    with atomic_write(path) as f:
        f.write(text)


def write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically (see :func:`atomic_write`)."""
    with atomic_write(path, "wb") as f:
        f.write(data)


def read_user_text(path: str | Path, what: str, error: type[UserError] = UserError) -> str:
    """The UTF-8 text of a file the user named; every failure (missing, a folder, not text, unreadable) is an
    ``error`` that starts with the path and names ``what`` the file should be."""
    path = Path(path)
    try:
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise error(f"{path}: no such {what}") from None
    except IsADirectoryError:
        raise error(f"{path}: is a folder, not a {what}") from None
    except UnicodeDecodeError as exc:
        raise error(f"{path}: not a text file ({exc.reason} at byte {exc.start})") from None
    except OSError as exc:
        raise error(f"{path}: cannot read the {what} ({exc.strerror or exc})") from None


def file_sha256(path: str | os.PathLike) -> str:
    """SHA-256 of a file's bytes, read in blocks (a mesh file may be large)."""
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()
