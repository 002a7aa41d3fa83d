"""Fanuc LS (TP text): the program writer and the program reader."""

from calibrator.languages.fanuc import reader, writer

__all__ = ["reader", "writer"]
