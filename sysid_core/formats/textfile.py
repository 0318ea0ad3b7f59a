"""A lab's text file read once, with bounds: the one reader of every text response format.

A user's wrong file (a binary capture named ``.csv``, a 2 GB dump, one line of 200 000
characters) is refused in one line naming the file, before it is read whole: its size is
checked first, its first block is checked for NUL bytes, and every line for its length. The
rules, for the toolkit's own CSV and for column-mapped exports alike:

* at most :data:`MAX_TEXT_BYTES` bytes: a sweep of a million frequencies in the toolkit's own
  layout (ten numbers of up to 24 characters a row) is about 250 MB; a larger file is not one
  sweep;
* no NUL byte in the first :data:`SNIFF_BYTES` (text never holds one);
* UTF-16 with its byte-order mark (Windows' "Unicode text"), else UTF-8 (a byte-order mark is
  allowed), else Latin-1 (an instrument's ``°`` or ``µ`` from a Windows PC);
* lines of at most :data:`MAX_LINE_CHARS` characters: a row of numbers is hundreds of
  characters, a header of a hundred named columns a few thousand.
"""

from __future__ import annotations

import csv
from pathlib import Path

from sysid_core.errors import FileFormatError

__all__ = [
    "MAX_LINE_CHARS",
    "MAX_TEXT_BYTES",
    "SNIFF_BYTES",
    "read_lines",
    "read_text",
    "split_fields",
]

#: The largest text response file read (bytes; see the module).
MAX_TEXT_BYTES = 256 * 1024**2
#: The first bytes checked for NUL before the file is read.
SNIFF_BYTES = 64 * 1024
#: The longest line read (characters; see the module).
MAX_LINE_CHARS = 65_536


def read_text(path: Path) -> str:
    """The decoded text of the file at ``path`` (see the module for the rules).

    Raises
    ------
    FileFormatError
        A missing file, one too large, one that is not text, or one with a line too long.
    """
    path = Path(path)
    if not path.is_file():
        raise FileFormatError(f"{path}: {'not a file' if path.exists() else 'no such file'}")
    size = path.stat().st_size
    if size > MAX_TEXT_BYTES:
        raise FileFormatError(
            f"{path}: {size / 1024**2:.0f} MB, more than a sweep's text can be "
            f"({MAX_TEXT_BYTES // 1024**2} MB holds a million frequencies): not a response file"
        )
    with open(path, "rb") as fh:
        head = fh.read(SNIFF_BYTES)
        utf16 = head.startswith((b"\xff\xfe", b"\xfe\xff"))
        nul = -1 if utf16 else head.find(b"\x00")
        if nul >= 0:
            raise FileFormatError(f"{path}: not a text file (a NUL byte at byte {nul + 1})")
        raw = head + fh.read()
    if utf16:
        try:
            text = raw.decode("utf-16")
        except UnicodeDecodeError as exc:
            raise FileFormatError(f"{path}: not a UTF-16 text file ({exc.reason})") from exc
    else:
        try:
            text = raw.decode("utf-8-sig")
        except UnicodeDecodeError:
            text = raw.decode("latin-1")
    if "\x00" in text:
        line = text.count("\n", 0, text.index("\x00")) + 1
        raise FileFormatError(f"{path}, line {line}: not a text file (it holds a NUL byte)")
    _check_lengths(text, path)
    return text


def read_lines(path: Path) -> list[str]:
    """The lines of the file at ``path`` (:func:`read_text`, split)."""
    return read_text(path).splitlines()


def _check_lengths(text: str, path: Path) -> None:
    """Refuse the first line over :data:`MAX_LINE_CHARS`, naming it."""
    if len(text) <= MAX_LINE_CHARS:
        return
    for number, line in enumerate(text.splitlines(), start=1):
        if len(line) > MAX_LINE_CHARS:
            raise FileFormatError(
                f"{path}, line {number}: {len(line)} characters, more than a line of a response "
                f"file holds ({MAX_LINE_CHARS}): not a response file, or a line break is missing"
            )


def split_fields(line: str, delimiter: str = ",") -> list[str]:
    """The fields of one line, stripped, without trailing empty fields (a trailing delimiter).

    ``delimiter`` is one character (quotes are honoured, as the ``csv`` module does) or
    ``"whitespace"``. Lines come from :func:`read_text`, never longer than the ``csv``
    module's field limit.
    """
    if delimiter == "whitespace":
        fields = line.split()
    else:
        fields = [f.strip() for f in next(csv.reader([line], delimiter=delimiter), [])]
    while fields and not fields[-1]:
        fields.pop()
    return fields
