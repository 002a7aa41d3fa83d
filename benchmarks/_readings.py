"""Shared by the tracker throughput benchmarks: single readings per second of a tracker."""

import time


def readings_per_second(tracker, readings, repeats, warm_up=500):
    """Rates (readings/s) of ``repeats`` timed runs of ``readings`` single readings each.

    ``warm_up`` readings first, untimed, fill caches and finish the simulator's imports.
    """
    for _ in range(warm_up):
        tracker.measure()
    rates = []
    for _ in range(repeats):
        start = time.perf_counter()
        for _ in range(readings):
            tracker.measure()
        rates.append(readings / (time.perf_counter() - start))
    return sorted(rates)
