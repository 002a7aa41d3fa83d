"""``calibrator check``: a quick re-check of a calibrated arm, its verdict and its explanation.

A handful of poses chosen for what drifts (:mod:`.poses`: joint zeros, base,
tool) is measured as ``measure`` measures; the calibration predicts where the
probe should be and how uncertain that prediction is (:mod:`.model`); the
verdict weighs the measured against that predicted error (:mod:`.verdict`)
and, on a failure, the smallest set of joint zeros and base motion that
explains the change is named (:mod:`.explain`); :mod:`.document` writes
check.json. Units: mm and rad; points in the tracker frame.
"""
