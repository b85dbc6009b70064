"""Reading a user's input files with bounds: one helper for every loader.

Scenario, study and topology files (TOML), rail profiles and earthquake records are named by the
user, so they may be anything: ``/dev/zero`` (read for ever, until memory runs out), a FIFO (blocks
for ever), a folder, a symbolic-link loop, binary data, or TOML nested ten thousand levels deep
(Python's parser recurses). :func:`read_text` refuses any file that is not a regular file, or above
a size limit, before reading it, and reads no more than the limit; :func:`loads_toml` refuses
nesting deeper than :data:`MAX_TOML_DEPTH`. Both raise :class:`InputFileError` (a ``ValueError``),
whose message is one line naming the file; each loader turns it into its own error type.

SymPy-free and NumPy-free: the generator's topology loader and the runtime both use it.
"""

from __future__ import annotations

import os
import re
import stat
import tomllib
from typing import Any

MiB = 2**20
MAX_TOML_BYTES = 16 * MiB
"""Largest scenario, study or topology file: a long scenario is a few kB."""
MAX_DATA_BYTES = 256 * MiB
"""Largest rail profile or earthquake record: a profile sampled every centimetre over 50 km is
about 150 MB of text; reading one takes several times its size in memory."""
MAX_TOML_DEPTH = 32
"""Deepest nesting of tables and arrays in a TOML input (svbi's files use at most four levels)."""


class InputFileError(ValueError):
    """An input file that cannot be read: the message is one line, ``<path>: <problem>``."""

    def __init__(self, path: str | os.PathLike[str], problem: str) -> None:
        self.path, self.problem = os.fspath(path), problem
        super().__init__(f"{self.path}: {problem}")


_KINDS = (
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def _kind(mode: int) -> str:
    for test, name in _KINDS:
        if test(mode):
            return name
    return "not a regular file"


def _size(n: int) -> str:
    return f"{n / MiB:.3g} MiB" if n >= MiB else f"{n} bytes"


def _stat_problem(st: os.stat_result, limit: int) -> str | None:
    if not stat.S_ISREG(st.st_mode):
        return f"is {_kind(st.st_mode)}, not a regular file"
    if st.st_size > limit:
        return f"is {_size(st.st_size)}, above the limit of {_size(limit)} for this kind of file"
    return None


def file_problem(path: str | os.PathLike[str], limit: int) -> str | None:
    """Why ``path`` cannot be read as an input file of at most ``limit`` bytes (missing, not a
    regular file, too large, a symbolic-link loop...), without opening it; None if it can."""
    try:
        st = os.stat(path)
    except OSError as exc:
        return f"cannot read ({exc.strerror or exc})"
    except ValueError as exc:  # a NUL byte in the name
        return f"cannot read ({exc})"
    return _stat_problem(st, limit)


def read_bytes(path: str | os.PathLike[str], limit: int) -> bytes:
    """The content of a regular file of at most ``limit`` bytes, else :class:`InputFileError`.

    The file is opened without blocking (a FIFO with no writer would block the open itself) and
    checked with ``fstat`` on the open descriptor, so that what is checked is what is read.
    """
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0)
    try:
        fd = os.open(path, flags)
    except OSError as exc:
        raise InputFileError(path, f"cannot read ({exc.strerror or exc})") from None
    try:
        st = os.fstat(fd)
        problem = _stat_problem(st, limit)
        if problem is not None:
            raise InputFileError(path, problem)
        if hasattr(os, "set_blocking"):
            os.set_blocking(fd, True)
        chunks: list[bytes] = []
        total = 0
        while total <= limit:  # a file that grows while it is read stops at the limit
            chunk = os.read(fd, min(limit + 1 - total, 1 << 20))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
        if total > limit:
            raise InputFileError(path, f"grew above the limit of {_size(limit)} while it was read")
        return b"".join(chunks)
    except OSError as exc:
        raise InputFileError(path, f"cannot read ({exc.strerror or exc})") from None
    finally:
        os.close(fd)


class TextFileError(InputFileError):
    """Bytes that are not UTF-8 text; ``where`` is ``file:line``, ``problem`` the rest."""

    def __init__(self, where: str, problem: str) -> None:
        self.where, self.path, self.problem = where, where.rsplit(":", 1)[0], problem
        ValueError.__init__(self, f"{where}: {problem}")


def decode_text(raw: bytes, name: str) -> str:
    """``raw`` decoded as UTF-8, a leading byte-order mark (Windows editors) dropped; text that is
    not UTF-8 is a :class:`TextFileError` naming ``name``, the line and the column of the first bad
    byte."""
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        column = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        raise TextFileError(
            f"{name}:{line}",
            f"not UTF-8 text (byte 0x{raw[exc.start]:02x} at column {column}); is this a binary file? "
            "A text file must be saved as UTF-8",
        ) from None


def read_text(path: str | os.PathLike[str], limit: int = MAX_TOML_BYTES, *, errors: str = "strict") -> str:
    """The UTF-8 text of a regular file of at most ``limit`` bytes (see :func:`read_bytes`), a
    leading byte-order mark dropped; with ``errors="strict"``, bytes that are not UTF-8 are a
    :class:`TextFileError` (:func:`decode_text`)."""
    data = read_bytes(path, limit)
    if errors == "strict":
        return decode_text(data, os.fspath(path))
    return data.decode("utf-8-sig", errors=errors)


def toml_depth(data: Any) -> int:
    """Nesting depth of parsed TOML (a table or array counts one level), without recursion."""
    deepest = 0
    stack: list[tuple[Any, int]] = [(data, 0)]
    while stack:
        value, depth = stack.pop()
        if isinstance(value, dict):
            children = list(value.values())
        elif isinstance(value, list):
            children = value
        else:
            continue
        deepest = max(deepest, depth + 1)
        stack.extend((child, depth + 1) for child in children)
    return deepest


class TOMLNestingError(ValueError):
    """TOML nested deeper than :data:`MAX_TOML_DEPTH` (Python's TOML parser recurses)."""


def loads_toml(text: str, max_depth: int = MAX_TOML_DEPTH) -> dict[str, Any]:
    """``tomllib.loads``, with nesting deeper than ``max_depth`` refused (:class:`TOMLNestingError`)
    instead of a ``RecursionError``; malformed TOML raises ``tomllib.TOMLDecodeError`` as usual."""
    try:
        data = tomllib.loads(text)
    except RecursionError:
        raise TOMLNestingError(f"nested more than {max_depth} levels deep") from None
    if toml_depth(data) > max_depth:
        raise TOMLNestingError(f"nested more than {max_depth} levels deep")
    return data


_HEADER = re.compile(r"^\s*\[\[?\s*([^\]\[]+?)\s*\]\]?\s*(?:#.*)?$")
_KEY = re.compile(
    r"^\s*((?:[A-Za-z0-9_\-]+|\"[^\"]*\"|'[^']*')(?:\s*\.\s*(?:[A-Za-z0-9_\-]+|\"[^\"]*\"|'[^']*'))*)\s*="
)


def _clean_key(raw: str) -> str:
    return ".".join(p.strip().strip("\"'") for p in raw.split("."))


def toml_key_lines(text: str) -> dict[str, int]:
    """Line number of every table header and key in TOML text, by dotted path (``[[a]]`` number
    ``i``, from 0, is ``a[i]``): the line that an error message about a key names."""
    lines: dict[str, int] = {}
    table = ""
    arrays: dict[str, int] = {}
    for number, line in enumerate(text.splitlines(), start=1):
        m = _HEADER.match(line)
        if m:
            table = _clean_key(m.group(1))
            lines.setdefault(table, number)
            if line.lstrip().startswith("[["):
                # an array of tables: [[bridge.girders]] number i is bridge.girders[i] (pydantic's key)
                index = arrays.get(table, 0)
                arrays[table] = index + 1
                table = f"{table}[{index}]"
                lines.setdefault(table, number)
            continue
        m = _KEY.match(line)
        if m:
            key = _clean_key(m.group(1))
            lines.setdefault(f"{table}.{key}" if table else key, number)
    return lines


def key_line(path: str, key: str) -> int | None:
    """The line of ``key`` (a dotted path, ``a[i].b`` for arrays of tables) in the TOML file
    ``path``, or of the nearest table above it that the file writes out; None when ``path`` is no
    readable file or names none of them. Never raises: it only adds a line to an error message."""
    try:
        if not os.path.isfile(path):
            return None
        lines = toml_key_lines(read_text(path, MAX_TOML_BYTES))
    except (OSError, ValueError):
        return None
    parts = key.split(".")
    while parts:
        found = lines.get(".".join(parts))
        if found is not None:
            return found
        last = parts[-1]
        if "[" in last:  # bodies[1] -> bodies (an inline array: its key's line)
            parts[-1] = last[: last.index("[")]
            continue
        parts.pop()
    return None
