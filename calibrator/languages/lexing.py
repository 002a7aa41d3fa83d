"""What of a program line is code: string literals and comments blanked, offsets kept.

Every language reader looks for its keywords (``movel(``, ``X =``, ``PTP``)
in the *code* of a line only: a ``movel(p[...])`` written inside
``textmsg("...")`` or after a comment mark is text, not a target. Each
language names its quotes and its comment opener once (:class:`Lexer`);
:meth:`Lexer.code` replaces what is not code by spaces, so positions found
in the result index the original line and a target's numbers are spliced
back where they were.
"""

from __future__ import annotations

import re
from dataclasses import dataclass


@dataclass(frozen=True)
class Lexer:
    """The strings and comments of one language.

    Attributes
    ----------
    quotes : str
        Characters that open and close a string literal (``"'`` for URScript).
    comment : str or None
        The opener of a comment running to the end of the line (``#``, ``;``, ``!``).
    """

    quotes: str = '"'
    comment: str | None = None

    def code(self, line: str) -> str:
        """``line`` with string contents and the comment replaced by spaces (same length).

        The quote characters themselves stay, so ``textmsg("a")`` still reads
        as a call with one (blank) string argument. An unterminated string
        runs to the end of the line.
        """
        special = self._special()
        at = special.search(line)
        if at is None:
            return line  # the usual line: nothing to blank
        parts, i = [], 0
        while at is not None:
            j = at.start()
            if self.comment is not None and line.startswith(self.comment, j):
                parts += [line[i:j], _blank(line[j:])]
                return "".join(parts)
            quote = line[j]
            end = line.find(quote, j + 1)
            if end < 0:  # unterminated: a string to the end of the line
                parts += [line[i : j + 1], _blank(line[j + 1 :])]
                return "".join(parts)
            parts += [line[i : j + 1], " " * (end - j - 1), quote]
            i = end + 1
            at = special.search(line, i)
        parts.append(line[i:])
        return "".join(parts)

    def _special(self) -> re.Pattern[str]:
        """The characters that open a string or a comment (compiled once per lexer)."""
        found = _PATTERNS.get(self)
        if found is None:
            opener = self.comment[0] if self.comment else ""
            found = _PATTERNS[self] = re.compile("[" + re.escape(self.quotes + opener) + "]")
        return found


_PATTERNS: dict[Lexer, re.Pattern[str]] = {}


def _blank(text: str) -> str:
    """``text`` as spaces, its line ending kept."""
    body = text.rstrip("\r\n")
    return " " * len(body) + text[len(body) :]
