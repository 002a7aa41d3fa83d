"""The tracker simulators' noise model: the one in :mod:`calibrator.simulate`.

Kept as a module so the simulators (and their users) import it from where
they always did; the model itself lives with the simulated world, so a
synthetic session and a simulated tracker draw from the same constants.
"""

from calibrator.model.noise import NoiseModel, beam_frame

__all__ = ["NoiseModel", "beam_frame"]
