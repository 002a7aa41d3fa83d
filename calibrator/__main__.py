"""``python -m calibrator``: the same as the ``calibrator`` command."""

from calibrator.cli import main

main()
