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
        if not any(q in line for q in self.quotes) and (
            self.comment is None or self.comment not in line
        ):
            return line  # the usual line: nothing to blank
        out = list(line)
        quote = None
        for i, ch in enumerate(line):
            if quote is not None:
                if ch == quote:
                    quote = None
                elif ch not in "\r\n":
                    out[i] = " "
            elif ch in self.quotes:
                quote = ch
            elif self.comment is not None and line.startswith(self.comment, i):
                for j in range(i, len(line)):
                    if line[j] not in "\r\n":
                        out[j] = " "
                break
        return "".join(out)
