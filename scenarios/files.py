"""Files written as a user expects of them: whole or not at all, with the permissions the umask gives."""

import os
import tempfile
from pathlib import Path as FilePath


def current_umask() -> int:
    """The process's file-creation mask (os.umask can only be read by setting it: set and restored)."""
    mask = os.umask(0o077)
    os.umask(mask)
    return mask


def permissions_as_umask(path, directory: bool = False) -> None:
    """Give ``path`` the permissions a plain ``open`` (``mkdir``) would: 0666 (0777) less the umask.
    tempfile's files and folders are private (0600, 0700), which would keep an artifact from the group."""
    os.chmod(path, (0o777 if directory else 0o666) & ~current_umask())


def write_text_atomically(path, chunks) -> FilePath:
    """Write the text ``chunks`` to ``path`` through a temporary file in the same folder and os.replace:
    an interrupted write leaves the previous file (or none), never half of one. The file's permissions
    are those the umask gives a new file."""
    path = FilePath(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.partial-")
    try:
        permissions_as_umask(tmp)
        with os.fdopen(fd, "w", newline="") as handle:
            handle.writelines(chunks)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return path
