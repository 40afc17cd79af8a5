"""Wall time per phase of a run (assemble, solve, backtrack, mesh motion, output …)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field


@dataclass
class Timers:
    """Accumulated wall time per phase: ``with timers("solve"): ...``; ``totals`` maps phase → seconds."""

    totals: dict = field(default_factory=dict)

    def add(self, name: str, seconds: float) -> None:
        self.totals[name] = self.totals.get(name, 0.0) + seconds

    class _Ctx:
        def __init__(self, timers, name):
            self.timers, self.name = timers, name

        def __enter__(self):
            self.t0 = time.perf_counter()

        def __exit__(self, *exc):
            self.timers.add(self.name, time.perf_counter() - self.t0)

    def __call__(self, name: str) -> Timers._Ctx:
        return Timers._Ctx(self, name)
