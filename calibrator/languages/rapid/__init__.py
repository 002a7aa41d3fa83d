"""RAPID (ABB): the program writer and the program reader."""

from calibrator.languages.rapid import reader, writer

__all__ = ["reader", "writer"]
