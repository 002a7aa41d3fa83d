"""The arm's mathematical model: what a calibration identifies and how it predicts.

- :mod:`~calibrator.model.kinematics`: Hayati-modified DH link transforms,
  batched forward kinematics and Jacobians (mm, rad);
- :mod:`~calibrator.model.frames`: rigid transforms on stacked arrays;
- :mod:`~calibrator.model.conventions`: exact conversions between DH
  families (MDH, standard DH, Craig's modified DH);
- :mod:`~calibrator.model.parameters`: which parameters are free and how
  they map to one vector;
- :mod:`~calibrator.model.measurement`: where the tracker sees the tool,
  residuals and their Jacobian;
- :mod:`~calibrator.model.joint_terms` and
  :mod:`~calibrator.model.mass_models`: joint error terms and the link masses
  their gravity torques need;
- :mod:`~calibrator.model.singularities`: how far a pose is from each of the
  arm's singularities;
- :mod:`~calibrator.model.inverse`: inverse kinematics of tool poses and the
  geometric Jacobian;
- :mod:`~calibrator.model.noise`: the laser tracker's noise model.

The named arms' tables live in :mod:`calibrator.robots`; nothing here does I/O
to hardware.
"""

#: The tool point on a bracket off the flange (flange frame, mm): the probe
#: position plans, the simulated cell and the commands' ``--tool`` assume when
#: none is given. Here, not in a module that loads numpy, so the command line
#: reads it for its defaults at no start-up cost.
DEFAULT_TOOL_MM = (0.0, 0.0, 100.0)
