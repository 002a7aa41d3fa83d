"""The planner's own sampling grows fourfold while too few candidates pass, and stops at its cap.

With a tracker 90 m away no candidate passes (beyond the tracker's range or
its acceptance angle): the planner samples 6000 candidates, four times
more, and so on up to :data:`calibrator.planning.planner.MAX_SAMPLED`
(400,000; lowered here to 24,000 to keep the test short), and says none of
the last set passes. At the cap it must stop: sampling the same seed again
finds the same nothing (a loop, so the call has a deadline).
"""

from __future__ import annotations

import pytest
from timeout_kit import within

from calibrator import cell as cells
from calibrator import planning, robots
from calibrator.planning import planner


def test_too_few_passing_at_the_cap_is_refused_with_the_caps_counts(monkeypatch):
    monkeypatch.setattr(planner, "MAX_SAMPLED", 24_000)
    far = cells.Cell(tracker_at_mm=(90000.0, 0.0, 300.0))

    def plan():
        with pytest.raises(planning.PlanError) as caught:
            planning.make_checked(robots.get("ur10e"), 12, far, (0.0, 0.0, 100.0))
        return str(caught.value)

    message = within(plan, 120.0, "the planner's refusal")
    assert message.startswith("only 0 of 24000 candidates pass the cell's checks")
    assert "tracker range" in message and "acceptance angle" in message
    assert message.endswith(
        "12 asked (more candidates, another tracker position or a smaller margin?)"
    )
