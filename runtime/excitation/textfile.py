"""Text of svbi's input files (scenarios, studies, profiles): UTF-8, with or without a byte-order mark.

Windows editors often start a UTF-8 file with a byte-order mark (BOM); it is accepted and dropped.
Text that is not UTF-8 is refused naming the file, the line and the column of the first bad byte.
"""

from __future__ import annotations


class TextFileError(ValueError):
    """A file that is not UTF-8 text; ``where`` is ``file:line``, ``problem`` the rest."""

    def __init__(self, where: str, problem: str) -> None:
        self.where = where
        self.problem = problem
        super().__init__(f"{where}: {problem}")


def decode_text(raw: bytes, name: str) -> str:
    """``raw`` decoded as UTF-8 (a leading byte-order mark dropped); ``name`` is the file's, for
    the message of :class:`TextFileError`."""
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = raw.count(b"\n", 0, exc.start) + 1
        column = exc.start - (raw.rfind(b"\n", 0, exc.start) + 1) + 1
        raise TextFileError(
            f"{name}:{line}",
            f"not UTF-8 text (byte 0x{raw[exc.start]:02x} at column {column}); save the file as UTF-8",
        ) from None
