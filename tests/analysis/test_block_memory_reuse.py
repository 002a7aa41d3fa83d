"""A Monte Carlo block reuses the memory the block before it freed (glibc).

Counted in page faults, not time: in a fresh process, two blocks run first,
then the page faults of the next two are counted. With glibc's default
thresholds each block maps its temporaries afresh (about 2,000 faults a
block); with the thresholds ``run_chunk`` raises, a few dozen.
"""

import platform
import subprocess
import sys

import pytest

pytestmark = pytest.mark.skipif(
    platform.libc_ver()[0] != "glibc", reason="the thresholds are glibc's"
)

_CHILD = """
import resource, sys
from calibrator.analysis import _malloc, arm, misalignment as mc
if sys.argv[1] == "default":
    _malloc.keep_freed_memory = lambda: False
s = mc.Study(arm.build(), 0.05, mc.PAPER_H_MM, 4 * mc.BLOCK, 0)
g = mc.make_grid(s)
mc.run_chunk(s, g, [0, 1])
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
mc.run_chunk(s, g, [2, 3])
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def faults_of_two_later_blocks(mode):
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, mode],
        check=True,
        capture_output=True,
        text=True,
        timeout=120,
    )
    return int(out.stdout)


def test_later_blocks_reuse_the_memory_earlier_blocks_freed():
    assert faults_of_two_later_blocks("raised") < 400
    # The same blocks with glibc's defaults: what the thresholds save.
    assert faults_of_two_later_blocks("default") > 2000


def test_the_thresholds_are_raised_once_and_say_so():
    from calibrator.analysis import _malloc

    assert _malloc.keep_freed_memory() is True
    assert _malloc.keep_freed_memory() is True and _malloc._done == [True]
