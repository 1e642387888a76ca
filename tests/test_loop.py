"""The one stepping loop's rules, shared by every back-end: when it checks, what it calls
unstable, how it counts samples and times them."""

from __future__ import annotations

import numpy as np

from tensim.sim._loop import (
    CHECK_EVERY,
    StabilityLimits,
    bad_acceleration,
    record_loop,
    sample_count,
    sample_time,
    stable,
)


class _Log:
    """A back-end that logs what the loop asks of it; it stops after ``stop`` records."""

    def __init__(self, stop: int = 10**9):
        self.calls: list[tuple[str, int]] = []
        self.k, self.stop = -1, stop

    def advance(self, k: int, nstep: int) -> bool:
        self.k = k
        self.calls.append(("advance", nstep))
        return k < self.stop

    def take(self) -> None:
        self.calls.append(("take", self.k))

    def check(self) -> None:
        self.calls.append(("check", self.k))


def test_loop_samples_first_then_steps_samples_and_checks_every_few_records():
    log, progress = _Log(), []
    record_loop(log, 12, 10, 0.01, 1.2, lambda done, total: progress.append((done, total)))
    assert log.calls[0] == ("take", -1)
    assert [c for c in log.calls if c[0] == "advance"] == [("advance", 10)] * 12
    assert [k for name, k in log.calls if name == "take"] == list(range(-1, 12))
    checks = [k for name, k in log.calls if name == "check"]
    assert checks == [*range(0, 12, CHECK_EVERY), 11]  # and always after the last record
    np.testing.assert_allclose(progress, [(1.0, 1.2)])  # about every simulated second


class _Stretches(_Log):
    """A back-end that takes records in stretches of at most ``most`` (as the compiled record
    loop does), asking the loop to check after the check records whose number is odd, and
    checking the others itself; after ``until`` records it can take no more."""

    def __init__(self, most: int, until: int):
        super().__init__()
        self.most, self.until = most, until
        self.stops: list[int] = []

    def records(self, k: int, stop: int) -> tuple[int, bool]:
        self.stops.append(stop)
        if k >= self.until:
            return k, False
        for j in range(k, min(stop, k + self.most)):
            self.advance(j, 10)
            self.take()
            if (j % CHECK_EVERY == 0 or j == 11) and j % 2:
                return j + 1, True
            if j % CHECK_EVERY == 0 or j == 11:
                self.check()
        return min(stop, k + self.most), False


def test_stretches_of_records_are_the_records_one_at_a_time():
    one, progress_one = _Log(), []
    record_loop(one, 12, 10, 0.01, 1.2, lambda done, total: progress_one.append(done))
    for most, until in ((3, 99), (100, 99), (4, 7)):  # the last: the rest one at a time
        log, progress = _Stretches(most, until), []
        record_loop(log, 12, 10, 0.01, 1.2, lambda done, total, seen=progress: seen.append(done))
        assert log.calls == one.calls and progress == progress_one
        assert set(log.stops) <= {10, 12}  # a stretch ends at a progress report or the end


def test_a_callback_per_record_takes_no_stretches():
    log, seen = _Stretches(100, 99), []
    record_loop(log, 12, 10, 0.01, 1.2, on_record=lambda: seen.append(log.k))
    assert log.stops == [] and seen == list(range(12))


def test_loop_stops_when_no_world_is_left_running():
    log = _Log(stop=3)
    record_loop(log, 12, 1, 0.01, 0.12)
    assert [c for c in log.calls if c[0] == "advance"] == [("advance", 1)] * 4
    assert log.calls[-1] == ("advance", 1)


def test_stable_fails_runaway_speed_force_nan_and_bad_acceleration():
    limits = StabilityLimits(max_speed=10.0, max_tension=100.0)
    qvel = np.array([[1.0, -2.0], [1.0, -10.0], [np.nan, 0.0], [0.0, 0.0], [0.0, 0.0],
                     [0.0, 0.0]])
    force = np.array([[-99.0], [0.0], [0.0], [-100.0], [np.nan], [0.0]])
    bad = np.array([0, 0, 0, 0, 0, 1])
    np.testing.assert_array_equal(stable(qvel, force, bad, limits),
                                  [True, False, False, False, False, False])
    assert stable(np.zeros(0), np.zeros(0), np.array(0), limits)  # no dofs, no cables


def test_bad_acceleration_is_mujocos_rule():
    qacc = np.array([[0.0, 1e10], [0.0, -1.0001e10], [np.nan, 0.0], [np.inf, 0.0]])
    np.testing.assert_array_equal(bad_acceleration(qacc), [False, True, True, True])


def test_sample_count_and_time_convention():
    assert sample_count(60.0, 10, 1e-3) == 6000  # 1e-9 slack for rounding of 60 / 0.01
    assert sample_count(0.0299, 10, 1e-3) == 2  # a part record is left out
    # data about to take step j describes t = (j - 1) dt
    times = sample_time(np.array([1e-3, 0.0101, 0.0099]), 1e-3)
    np.testing.assert_array_equal(times, [0.0 * 1e-3, 9 * 1e-3, 9 * 1e-3])
