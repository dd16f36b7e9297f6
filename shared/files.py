"""Reading a file a user names: bounded, and only a regular file.

A cell file, a password, a key or a certificate is a few kilobytes. Whatever a path names is
read through here, so that a mistake (``--config /dev/zero``, a FIFO, a log file given for a
cell file, a binary file) is one line saying so, never a read without end, a hang on a pipe
or a decoding traceback.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

CELL_FILE_LIMIT = 1 << 20
"""1 MiB: the largest cell file read. A four-group cell with robot models of its own is under
10 KiB."""
SECRET_LIMIT = 64 << 10
"""64 KiB: the largest password, key or certificate read (a 4096-bit RSA key is 3.3 KiB)."""


class FileRefusedError(ValueError):
    """A file that is no regular file, too large, or not text: the message says which."""


def read_bounded(path: Path, limit: int) -> bytes:
    """``path``'s bytes, at most ``limit`` of them: FileRefusedError for a larger file or one that
    is no regular file (a device, a FIFO, a directory); OSError for one that cannot be
    opened."""
    # Non-blocking, so that opening a FIFO with no writer returns at once and is refused.
    descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    try:
        mode = os.fstat(descriptor).st_mode
        if not stat.S_ISREG(mode):
            raise FileRefusedError(f"{path} is not a regular file ({_kind(mode)})")
        chunks = []
        left = limit + 1  # one more than allowed tells a file at the limit from a larger one
        while left > 0:
            chunk = os.read(descriptor, left)
            if not chunk:
                break
            chunks.append(chunk)
            left -= len(chunk)
    finally:
        os.close(descriptor)
    data = b"".join(chunks)
    if len(data) > limit:
        raise FileRefusedError(f"{path} is larger than {_size(limit)}: not the file meant?")
    return data


def read_text_bounded(path: Path, limit: int) -> str:
    """``path``'s text (UTF-8), as ``read_bounded`` reads it; FileRefusedError for binary data."""
    data = read_bounded(path, limit)
    try:
        return data.decode()
    except UnicodeDecodeError as exc:
        raise FileRefusedError(
            f"{path} is not a text file (no UTF-8 at byte {exc.start}): not the file meant?"
        ) from None


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISFIFO(mode):
        return "a FIFO"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a file"


def _size(limit: int) -> str:
    return f"{limit >> 20} MiB" if limit >= 1 << 20 else f"{limit >> 10} KiB"
