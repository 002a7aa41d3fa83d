"""JBI (Yaskawa/Motoman INFORM): the program reader (no writer)."""

from calibrator.languages.jbi import reader

__all__ = ["reader"]
