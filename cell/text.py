"""Printing what a user wrote: every message that echoes a value, a key or a file name
goes through :func:`escape` or :func:`show`, so no message can carry terminal escapes or
run to thousands of characters.
"""

from __future__ import annotations

import math
from typing import Any

__all__ = ["escape", "override_source", "show"]

_SHOW_MAX = 80  # characters of a value echoed in a message
_SOURCE_MAX = 100  # characters of a --set assignment echoed as the source of an error
_SHOW_DIGITS = 40  # an integer with more digits is shown by its length
_ESCAPES = {"\n": "\\n", "\r": "\\r", "\t": "\\t"}


def escape(text: str) -> str:
    """``text`` with every non-printable character written as a Python escape.

    ``"a\\x1b[2J"`` for an ESC, ``\\n`` for a newline: safe to print in a terminal. Printable
    text (backslashes included) is unchanged, so escaping twice changes nothing.
    """
    return "".join(c if c.isprintable() else _escape_char(c) for c in text)


def _escape_char(c: str) -> str:
    code = ord(c)
    if c in _ESCAPES:
        return _ESCAPES[c]
    if code < 0x100:
        return f"\\x{code:02x}"
    if code < 0x10000:
        return f"\\u{code:04x}"
    return f"\\U{code:08x}"


def _digits(n: int) -> int:
    """Decimal digits of ``abs(n)``, without converting it to text (which fails past 4300)."""
    n = abs(n)
    if n < 10:
        return 1
    d = int((n.bit_length() - 1) * math.log10(2)) + 1
    return d + 1 if n >= 10**d else d


def summary(value: Any) -> str | None:
    """What to show instead of a ``repr`` that would be too long or would fail, else None."""
    if isinstance(value, int) and not isinstance(value, bool) and _digits(value) > _SHOW_DIGITS:
        return f"an integer of {_digits(value)} digits"
    try:
        repr(value)
    except (ValueError, RecursionError):  # holds an integer too long to print, or too deep
        return f"a {type(value).__name__} too large to show"
    return None


def show(value: Any, limit: int = _SHOW_MAX) -> str:
    """A short, printable rendering of a user's value for an error message.

    An integer of more than 40 digits is shown by its length; anything else by its
    ``repr``, escaped and cut to ``limit`` characters (at least 4; default 80).
    """
    text = summary(value)
    if text is not None:
        return text
    text = escape(repr(value))
    return text if len(text) <= limit else text[: max(limit, 4) - 3] + "..."


def override_source(assignment: str) -> str:
    """How a ``--set`` assignment is named in messages: escaped, cut to 100 characters."""
    text = escape(assignment)
    return "--set " + (text if len(text) <= _SOURCE_MAX else text[: _SOURCE_MAX - 3] + "...")
