"""The fixed-rate clock of the loop: :class:`RateClock` keeps the period on CPython --
it sleeps until ``spin`` seconds before each deadline and busy-waits the rest (a plain
``time.sleep`` wakes 80-115 us late on this kind of machine; sleeping short and spinning
brings the median to ~0) -- and counts every tick's lateness and the deadlines missed by
more than a period."""

from __future__ import annotations

import time

import numpy as np


class RateClock:
    """Ticks every ``period`` s from the first :meth:`wait`; keeps each tick's lateness."""

    def __init__(self, period: float, spin: float = 2e-4, capacity: int = 1 << 20) -> None:
        self.period = float(period)
        self.spin = float(spin)
        self.late = np.zeros(capacity)
        self.n = 0
        self.next = 0.0

    def start(self) -> None:
        self.next = time.perf_counter() + self.period

    def wait(self) -> float:
        """Wait for the next deadline; returns how late it was reached (s)."""
        sleep = self.next - self.spin - time.perf_counter()
        if sleep > 0:
            time.sleep(sleep)
        while True:
            now = time.perf_counter()
            if now >= self.next:
                break
        late = now - self.next
        if self.n < len(self.late):
            self.late[self.n] = late
        self.n += 1
        self.next += self.period
        if late > self.period:  # missed: resynchronise instead of running to catch up
            self.next = now + self.period
        return late

    def stats(self) -> dict[str, float]:
        """Lateness p50/p99/p99.9/max (us) and deadlines missed by more than a period."""
        return lateness_stats(self.late[: min(self.n, len(self.late))], self.period, self.n)


def lateness_stats(late: np.ndarray, period: float, ticks: int | None = None
                   ) -> dict[str, float]:
    """The ticks' lateness ``late`` (s) as the session's summary keeps it: its p50, p99,
    p99.9 and max (us) and how many deadlines were missed by more than a ``period``; over
    ``ticks`` waits (default ``len(late)``)."""
    x = np.asarray(late) * 1e6
    if not len(x):
        return {"ticks": 0}
    return {"ticks": int(len(x) if ticks is None else ticks),
            "p50_us": float(np.percentile(x, 50)),
            "p99_us": float(np.percentile(x, 99)),
            "p999_us": float(np.percentile(x, 99.9)), "max_us": float(x.max()),
            "missed": int((x > period * 1e6).sum())}
