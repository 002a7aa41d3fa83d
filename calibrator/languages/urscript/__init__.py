"""URScript (Universal Robots): the program writer and the program reader."""

from calibrator.languages.urscript import reader, writer

__all__ = ["reader", "writer"]
