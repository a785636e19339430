"""Fast parsing of whitespace/comma separated numbers, streamed in chunks."""
from __future__ import annotations

import re
import warnings
from typing import Iterator, Optional, Tuple

import numpy as np

from ..errors import FormatError

__all__ = ["parse_rows", "iter_text_chunks", "split_tokens"]

_SEPARATORS = re.compile(r"[,;\t ]+")


def split_tokens(line: str) -> list:
    """Tokens of one line; separators are spaces, tabs, commas and semicolons."""
    return [t for t in _SEPARATORS.split(line.strip()) if t]


def _fast(text: str) -> Optional[np.ndarray]:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            return np.fromstring(text, dtype=np.float64, sep=" ")
    except (DeprecationWarning, ValueError):
        return None


def parse_rows(text: str, ncols: int, path: str, first_line: int, *, commas: bool = False) -> np.ndarray:
    """Parse lines of numbers into an array.

    Parameters
    ----------
    text : str
        Complete lines (blank lines are skipped).
    ncols : int
        Numbers expected on every line.
    path : str
        File named in errors.
    first_line : int
        1-based line number of the first line of ``text`` in the file (for messages).
    commas : bool
        Also accept commas, semicolons and tabs as separators.

    Returns
    -------
    (m, ncols) float64

    Raises
    ------
    FormatError
        A line has the wrong number of values or a value is not a number; the message gives
        the line number.
    """
    src = text
    if commas:
        src = text.replace(",", " ").replace(";", " ")
    values = _fast(src)
    if values is not None:
        nlines = src.count("\n") + (0 if src.endswith("\n") or not src else 1)
        if values.size == nlines * ncols:
            return values.reshape(-1, ncols)
    # slow path: blank lines, a bad line or a bad value -> find it line by line
    rows = []
    for k, line in enumerate(text.splitlines()):
        tokens = split_tokens(line) if commas else line.split()
        if not tokens:
            continue
        if len(tokens) != ncols:
            raise FormatError(f"line {first_line + k}: {len(tokens)} values, expected {ncols} "
                              f"(wrong column count)", path)
        try:
            rows.append([float(t) for t in tokens])
        except ValueError:
            raise FormatError(f"line {first_line + k}: not a number in {line.strip()[:60]!r}", path) from None
    return np.asarray(rows, dtype=np.float64).reshape(-1, ncols)


def iter_text_chunks(f, chunk_bytes: int, first_line: int) -> Iterator[Tuple[str, int, int]]:
    """Yield ``(text, first_line_number, bytes_read_so_far)`` of whole lines from a text file
    opened in binary mode, about ``chunk_bytes`` at a time."""
    rest = b""
    line = first_line
    done = 0
    while True:
        block = f.read(chunk_bytes)
        if not block:
            if rest.strip():
                yield rest.decode("utf-8", errors="replace"), line, done
            return
        done += len(block)
        block = rest + block
        cut = block.rfind(b"\n")
        if cut < 0:
            rest = block
            continue
        body, rest = block[: cut + 1], block[cut + 1:]
        text = body.decode("utf-8", errors="replace")
        yield text, line, done
        line += text.count("\n")
