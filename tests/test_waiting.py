"""The servo loop's hybrid wait (sleep, then spin on the clock): on a fake clock."""

from __future__ import annotations

import pytest

from redservo.errors import ConfigurationError
from redservo.hardware.waiting import HybridSleep


class LateClock:
    """A fake clock whose sleeps overshoot by ``late`` s and whose reads take ``tick`` s."""

    def __init__(self, late: float, tick: float = 1e-5) -> None:
        self.t, self.late, self.tick, self.sleeps, self.reads = 100.0, late, tick, [], 0

    def clock(self) -> float:
        self.t += self.tick
        self.reads += 1
        return self.t

    def sleep(self, dt: float) -> None:
        self.sleeps.append(dt)
        self.t += dt + self.late


def test_it_sleeps_short_of_the_deadline_then_spins_to_it() -> None:
    fake = LateClock(late=0.0015)  # the kernel wakes the sleeper 1.5 ms late
    wait = HybridSleep(0.002, fake.clock, fake.sleep)
    start = fake.clock()
    wait(0.04)
    assert fake.sleeps == [pytest.approx(0.038)]
    assert 0.04 <= fake.t - start <= 0.04 + 3e-5  # on time to a few clock reads
    assert fake.reads > 10  # it did spin


def test_a_plain_sleep_is_late_by_the_wake_up() -> None:
    fake = LateClock(late=0.0015)
    start = fake.clock()
    HybridSleep(0.0, fake.clock, fake.sleep)(0.04)
    assert fake.t - start == pytest.approx(0.0415, abs=3e-5)


def test_a_wait_shorter_than_the_spin_only_spins_and_none_returns_at_once() -> None:
    fake = LateClock(late=1.0)
    HybridSleep(0.002, fake.clock, fake.sleep)(0.001)
    HybridSleep(0.002, fake.clock, fake.sleep)(-0.5)
    assert fake.sleeps == []


@pytest.mark.parametrize("bad", [-0.001, float("nan"), float("inf"), "2ms", True])
def test_a_bad_spin_is_one_error_naming_it(bad: object) -> None:
    with pytest.raises(ConfigurationError, match="spin must be a finite number") as e:
        HybridSleep(bad)  # type: ignore[arg-type]
    assert e.value.argument == "spin"
