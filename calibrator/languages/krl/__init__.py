"""KRL (KUKA): the program writer (.src) and the program reader (.src with its .dat)."""

from calibrator.languages.krl import reader, writer

__all__ = ["reader", "writer"]
