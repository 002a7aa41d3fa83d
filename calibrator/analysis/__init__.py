"""Accuracy analysis: what an arm's build tolerances do to its hand pose.

``misalignment``
    Monte Carlo of joint-axis misalignment inside bearing clearances
    (error transform E_i per joint, the misalignment paper).
``tolerance``
    Linear tolerance budget dS = J dp from link-parameter and joint
    deviations, worst case and statistical, checked against the nonlinear
    model (Chen and Zhang 1984, the deflection paper).
``engine``
    Runs the Monte Carlo's chunks in-process or on a Dask cluster, with
    results that do not depend on the chunking or the worker count.
"""
