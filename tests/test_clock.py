from __future__ import annotations

import numpy as np
import pytest

from humimic.sensors.clock import Clock, Schedule


@pytest.mark.parametrize("rate", [420, 60, 30, 180, 100, 840, 7.0])
def test_schedule_keeps_the_mean_rate_and_bounded_jitter(rate):
    clock = Clock(840.0)
    n = clock.ticks_for(10.0)
    sched = Schedule(rate, 840.0)
    ticks = np.array([k for k in range(n) if sched.due(k)])
    times = ticks / 840.0
    nominal = np.arange(len(ticks)) / rate
    assert len(ticks) == pytest.approx(10.0 * rate, abs=1)
    # each sample at the first physics tick at or after its nominal time
    assert np.all(times >= nominal - 1e-12)
    assert np.all(times - nominal < 1 / 840.0)
    assert np.array_equal(ticks, Schedule(rate, 840.0).ticks(n))


def test_exact_divisors_are_exactly_periodic():
    ticks = Schedule(60, 840).ticks(840)
    assert np.all(np.diff(ticks) == 14) and ticks[0] == 0


def test_rate_out_of_range_is_rejected():
    with pytest.raises(ValueError):
        Schedule(0.0, 840.0)
    with pytest.raises(ValueError):
        Schedule(1000.0, 840.0)
