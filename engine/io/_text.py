"""Fast parsing of separated numbers, streamed in chunks, and the rules that tell a text
file's separator and decimal mark apart."""
from __future__ import annotations

import re
import warnings
from typing import Iterator, Optional, Tuple

import numpy as np

from ..errors import FormatError

__all__ = ["parse_rows", "iter_text_chunks", "split_tokens", "take_lines", "count_lines", "TextStyle",
           "detect_style"]

_SEPARATORS = re.compile(r"[,;\t ]+")
_SPLIT = {"space": re.compile(r"[\t ]+"), "comma": re.compile(r"[,\t ]+"),
          "semicolon": re.compile(r"[;\t ]+")}
_BLANK_LINE = re.compile(r"(?:^|\n)[ \t\r\f\v]*(?:\n|\Z)")
_DECIMAL_COMMA = re.compile(r"[+-]?[0-9]*,[0-9]+(?:[eE][+-]?[0-9]+)?")
"""A number written with a comma as decimal mark: ``8,7751``, ``-0,5``, ``1,5E+03``."""


def split_tokens(line: str) -> list:
    """Tokens of one line; separators are spaces, tabs, commas and semicolons."""
    return [t for t in _SEPARATORS.split(line.strip()) if t]


class TextStyle:
    """How the numbers of a text file are written.

    Attributes
    ----------
    sep : {"space", "comma", "semicolon"}
        The field separator: whitespace only; commas (and whitespace); semicolons (and
        whitespace).
    decimal : {".", ",", None}
        The decimal mark; None while no number with a fraction has been seen (a file of
        integers). With ``sep="comma"`` it is always ``"."``.
    """

    def __init__(self, sep: str = "comma", decimal: Optional[str] = "."):
        self.sep = sep
        self.decimal = decimal

    def tokens(self, line: str) -> list:
        """The fields of one line (decimal commas not yet converted)."""
        return [t for t in _SPLIT[self.sep].split(line.strip()) if t]

    def __repr__(self):
        return f"TextStyle(sep={self.sep!r}, decimal={self.decimal!r})"


def detect_style(lines, path: str) -> TextStyle:
    """Tell the separator and the decimal mark from the first data lines of a text file.

    Rules (a number with a comma inside is read as a decimal-comma number only when the
    comma cannot be a separator):

    * any ``;`` -> semicolons separate fields; a field with one comma between digits
      (``8,7751``) means a decimal comma. ``8,7751;0,1627;1,2500`` is x = 8.7751,
      y = 0.1627, z = 1.25.
    * otherwise, fields separated by whitespace that hold a comma between digits
      (``8,77 0,16 1,25``, tab separated alike) -> decimal comma;
    * otherwise commas (with or without spaces) separate fields and ``.`` is the decimal
      mark (ordinary CSV); a file with neither commas nor semicolons is whitespace
      separated.

    Parameters
    ----------
    lines : sequence of str
        Non-blank data lines (no header or count lines).
    path : str
        Named in errors.

    Raises
    ------
    FormatError
        Ambiguous: a field with both ``.`` and ``,`` (``1.234,5``: a thousands separator?),
        a field with two commas in a semicolon or whitespace separated file, or lines that
        use commas both as separators and inside numbers.
    """
    if any(";" in ln for ln in lines):
        style = TextStyle("semicolon", None)
        for k, ln in enumerate(lines):
            for t in style.tokens(ln):
                _decimal_field(style, t, path, k, ln)
        return style
    inner = sep = both = False  # commas inside fields / commas as separators / a mix in one field
    for ln in lines:
        if "," not in ln:
            continue
        fields = ln.split()
        if len(fields) < 2:  # "1.5,2.5,3.5": no whitespace, so the commas separate
            sep = True
            continue
        for t in fields:
            if "," not in t:
                continue
            core = t.strip(",")
            if core != t:  # "1," or ",": a separating comma ...
                sep = True
                both |= "," in core and "." not in core  # ... after "1,5": a decimal comma too?
            elif _DECIMAL_COMMA.fullmatch(t):
                inner = True
            else:  # "1.5,2.5" or "1,2,3": separating commas
                sep = True
    if both:
        raise FormatError("cannot tell whether ',' is a decimal mark or a separator (fields like "
                          "'1,5,' with spaces between them); save the file with one convention", path)
    if inner and sep:
        raise FormatError("cannot tell whether ',' is a decimal mark or a separator: some lines have "
                          "numbers like '8,77' separated by spaces, others use ',' between values; "
                          "save the file with one convention", path)
    if inner:
        style = TextStyle("space", ",")
        for k, ln in enumerate(lines):
            for t in style.tokens(ln):
                _decimal_field(style, t, path, k, ln)
        return style
    if sep:
        return TextStyle("comma", ".")
    style = TextStyle("space", None)
    if any("." in ln for ln in lines):
        style.decimal = "."
    return style


def _decimal_field(style: TextStyle, t: str, path: str, k: int, line: str) -> None:
    """Record the decimal mark a field shows in ``style``; refuse an ambiguous field."""
    has_c, has_d = "," in t, "." in t
    if has_c and has_d:
        raise FormatError(f"data line {k + 1}: {t[:40]!r} has both ',' and '.': ambiguous decimal mark "
                          "(a thousands separator?)", path)
    if has_c and not _DECIMAL_COMMA.fullmatch(t):
        raise FormatError(f"data line {k + 1}: cannot read {t[:40]!r} (',' is the decimal mark of this "
                          "file but the field is not one number)", path)
    mark = "," if has_c else "." if has_d else None
    if mark is None:
        return
    if style.decimal is not None and style.decimal != mark:
        raise FormatError(f"data line {k + 1}: {line.strip()[:60]!r} mixes ',' and '.' as decimal marks",
                          path)
    style.decimal = mark


def _fast(text: str) -> Optional[np.ndarray]:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            return np.fromstring(text, dtype=np.float64, sep=" ")
    except (DeprecationWarning, ValueError):
        return None


def _line_of(text: str, pos: int, first_line: int) -> int:
    return first_line + text.count("\n", 0, pos)


def _apply_style(text: str, style: TextStyle, path: str, first_line: int) -> str:
    """``text`` with the style's separators made spaces and decimal commas made dots.

    With ``sep`` space or semicolon and an undecided or comma decimal mark, a chunk holding
    both ``,`` and ``.`` (or the other mark than earlier chunks) is refused: never misread.
    """
    if style.sep == "comma":
        return text.replace(",", " ")
    if style.sep == "semicolon":
        text_sep = text.replace(";", " ")
    else:
        text_sep = text
    ci, di = text.find(","), text.find(".")
    if ci >= 0 and di >= 0:
        pos = max(ci, di)
        raise FormatError(f"line {_line_of(text, pos, first_line)}: mixes ',' and '.' as decimal marks "
                          f"with the lines before it", path)
    mark = "," if ci >= 0 else "." if di >= 0 else None
    if mark is not None:
        if style.decimal is not None and style.decimal != mark:
            pos = ci if mark == "," else di
            raise FormatError(f"line {_line_of(text, pos, first_line)}: '{mark}' used as decimal mark, "
                              f"but earlier lines use '{style.decimal}'", path)
        style.decimal = mark
    return text_sep.replace(",", ".") if mark == "," else text_sep


def parse_rows(text: str, ncols: int, path: str, first_line: int, *, commas: bool = False,
               style: Optional[TextStyle] = None) -> np.ndarray:
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
        Also accept commas, semicolons and tabs as separators (ignored with ``style``).
    style : TextStyle, optional
        The file's separator and decimal mark (see :func:`detect_style`); updated when this
        chunk first shows the decimal mark.

    Returns
    -------
    (m, ncols) float64

    Raises
    ------
    FormatError
        A line has the wrong number of values or a value is not a number; the message gives
        the line number. With ``style``: a chunk mixing decimal marks.
    """
    if style is not None:
        src = _apply_style(text, style, path, first_line)
    elif commas:
        src = text.replace(",", " ").replace(";", " ")
    else:
        src = text
    values = _fast(src)
    if values is not None:
        nlines = src.count("\n") + (0 if src.endswith("\n") or not src else 1)
        if values.size == nlines * ncols:
            return values.reshape(-1, ncols)
    # slow path: blank lines, a bad line or a bad value -> find it line by line
    rows = []
    for k, (line, conv) in enumerate(zip(text.splitlines(), src.splitlines())):
        if style is not None:
            tokens = conv.split()
        elif commas:
            tokens = split_tokens(line)
        else:
            tokens = line.split()
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


def take_lines(text: str, k: int) -> Tuple[str, str]:
    """Split ``text`` after its first ``k`` non-blank lines: ``(head, rest)``; ``rest`` is
    empty when ``text`` holds no more than ``k`` non-blank lines."""
    if k <= 0:
        return "", text
    if text.count("\n") < k:
        return text, ""
    pieces = text.split("\n", k)
    head = "\n".join(pieces[:k]) + "\n"
    if not _BLANK_LINE.search(head[:-1]):
        return head, pieces[k]
    lines = text.splitlines(keepends=True)  # blank lines among them: count the others
    seen = 0
    for i, line in enumerate(lines):
        seen += bool(line.strip())
        if seen == k:
            return "".join(lines[:i + 1]), "".join(lines[i + 1:])
    return text, ""


def count_lines(text: str) -> int:
    """Number of non-blank lines in ``text``."""
    if not text:
        return 0
    n = text.count("\n") + (0 if text.endswith("\n") else 1)
    if _BLANK_LINE.search(text[:-1] if text.endswith("\n") else text):
        n = sum(1 for line in text.splitlines() if line.strip())
    return n


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
