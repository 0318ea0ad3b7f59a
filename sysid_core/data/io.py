"""Safe file writing: atomic, with the user's umask, never over something it must not replace.

* :func:`atomic_write`: a file is either the old version or the complete new one, never half.
* :func:`check_output_file`: refuse to write over an input, a symlink, a non-regular file, or
  (without ``force``) an existing file.
"""

from __future__ import annotations

import json
import os
import stat
import tempfile
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from sysid_core.errors import OutputError

__all__ = [
    "atomic_write",
    "check_output_file",
    "current_umask",
    "json_line",
    "json_text",
    "write_json",
]


def current_umask() -> int:
    """The process's umask, read without changing it where the system allows.

    Linux reports it in ``/proc/self/status``; elsewhere it is read by setting and restoring it.
    """
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _refuse_special(path: Path) -> None:
    """Refuse a symlink or a non-regular file at ``path`` (atomic replacement would destroy it)."""
    if path.is_symlink():
        raise OutputError(
            f"refusing to write {path}: it is a symbolic link (to {os.readlink(path)}); "
            "give the real file's path or another name"
        )
    if path.exists() and not stat.S_ISREG(path.stat().st_mode):
        kind = "a directory" if path.is_dir() else "not a regular file"
        raise OutputError(f"refusing to write {path}: it is {kind}; choose another name")


def check_output_file(
    path: str | os.PathLike[str],
    inputs: Iterable[str | os.PathLike[str]] = (),
    force: bool = False,
) -> Path:
    """Check that ``path`` may be written; return it.

    Raises
    ------
    OutputError
        If ``path`` is one of ``inputs`` (whatever ``force``), a symbolic link or a non-regular
        file (whatever ``force``), or an existing file and ``force`` is false.
    """
    path = Path(path)
    for item in inputs:
        src = Path(item)
        if src.exists() and path.exists() and os.path.samefile(src, path):
            raise OutputError(
                f"refusing to write over the input file {src}: choose another output name"
            )
    _refuse_special(path)
    if path.exists() and not force:
        raise OutputError(f"{path} already exists; pass --force to replace it")
    return path


def atomic_write(path: str | os.PathLike[str], writer: Callable[[Path], object]) -> Path:
    """Call ``writer(tmp_path)`` and move the result to ``path`` in one ``os.replace``.

    The temporary file lives in the destination directory (same file system) and is removed if
    ``writer`` fails, so an earlier file at ``path`` stays readable. The new file gets the
    permissions a newly created file would (``0o666`` minus the umask). A symbolic link or a
    non-regular file at ``path`` is never replaced (:class:`~sysid_core.errors.OutputError`).
    """
    path = Path(path)
    _refuse_special(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        writer(tmp)
        os.chmod(tmp, 0o666 & ~current_umask())
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return path


def write_json(
    path: str | os.PathLike[str], obj: Any, lines: dict[str, list[str]] | None = None
) -> Path:
    """Write ``obj`` as indented JSON, atomically (NaN and infinity are written as ``null``).

    ``lines``: keys to append to ``obj`` (a dict), each a list already encoded one item per
    line (:func:`json_line`): a long list, such as a run's history, is written without being
    encoded again.
    """
    text = json_text(obj, lines)
    return atomic_write(path, lambda tmp: tmp.write_text(text))


def json_line(obj: Any) -> str:
    """``obj`` as one line of strict JSON (NaN and infinity as ``null``)."""
    return json.dumps(_finite(obj), allow_nan=False, separators=(", ", ": "))


def json_text(obj: Any, lines: dict[str, list[str]] | None = None) -> str:
    """The text :func:`write_json` writes (indented; ``lines`` as there)."""
    text = json.dumps(_finite(obj), indent=2, sort_keys=False, allow_nan=False)
    if lines:
        if not isinstance(obj, dict) or set(obj) & set(lines):
            raise ValueError("lines are keys to add to a dict that does not have them")
        added = [
            f"  {json.dumps(key)}: "
            + ("[\n    " + ",\n    ".join(items) + "\n  ]" if items else "[]")
            for key, items in lines.items()
        ]
        text = (text[:-2] + ",\n" if obj else "{\n") + ",\n".join(added) + "\n}"
    return text + "\n"


def _finite(obj: Any) -> Any:
    """``obj`` with every non-finite float replaced by ``None`` (strict JSON has no NaN)."""
    if isinstance(obj, float):
        return obj if obj == obj and obj not in (float("inf"), float("-inf")) else None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    return obj
