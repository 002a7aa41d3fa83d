"""The same study on a real Dask LocalCluster gives the in-process result, to the bit."""

import multiprocessing

from calibrator.analysis import arm, engine
from calibrator.analysis import misalignment as mc


def test_local_cluster_matches_in_process():
    study = mc.Study(arm.build(), 0.05, mc.PAPER_H_MM, 2 * mc.BLOCK + 500, seed=3)
    local, grid = engine.run(study)
    seen = []
    remote, _ = engine.run(
        study, workers=2, chunk_trials=mc.BLOCK, progress=lambda d, t: seen.append((d, t))
    )
    assert mc.statistics(remote, grid) == mc.statistics(local, grid)
    assert seen[-1] == (study.trials, study.trials) and len(seen) == 3
    # The cluster's worker processes are gone once the run returns.
    assert multiprocessing.active_children() == []
