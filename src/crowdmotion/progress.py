"""Progress bars for the methods' step loops: a total, and a clock that starts after the
first step, so loading (or, on a first run, compiling) the kernels does not make the ETA
read hours."""

from __future__ import annotations

from contextlib import contextmanager
from typing import Iterator

from tqdm.auto import tqdm

FIRST = "first step: loading its kernels (compiled on a first run, then cached)"
# tqdm's monitor thread outlives the bars; with it alive a later run in this process
# could not compile its kernels on all cores (crowdmotion._precompile forks only a
# process without other threads). Our bars update every step: they need no monitor.
tqdm.monitor_interval = 0


class StepBar:
    """``done(n)`` reports n steps done in all, ``advance(k)`` k more."""

    def __init__(self, bar: tqdm):
        self.bar = bar
        self.started = False

    def done(self, n: int) -> None:
        if not self.started:  # the first report: restart the clock from here
            self.started = True
            self.bar.reset(total=self.bar.total)
            self.bar.initial = self.bar.n = self.bar.last_print_n = n
            self.bar.set_postfix_str("")
            self.bar.refresh()
            return
        self.bar.update(n - self.bar.n)

    def advance(self, k: int = 1) -> None:
        self.done(self.bar.n + k)


# step loops (a method's run inside its step bar) under way and finished in this process
_LOOPS = {"open": 0, "finished": 0}


def step_loops() -> tuple[int, int]:
    """(step loops under way, step loops finished) in this process: the command tells from
    them whether a Ctrl-C stops a loop (which keeps its frames so far) or comes after one."""
    return _LOOPS["open"], _LOOPS["finished"]


@contextmanager
def step_bar(total: int | None, desc: str, enabled: bool = True, unit: str = "step", file=None) -> Iterator[StepBar]:
    """A bar of ``total`` steps (shown after a second; on ``file``, default stderr) that
    says it is loading its kernels until the first step is reported. The method's step
    loop runs inside it (counted by :func:`step_loops`)."""
    _LOOPS["open"] += 1
    try:
        with tqdm(total=total, desc=desc, unit=unit, disable=not enabled, delay=1.0, leave=False, file=file) as bar:
            bar.set_postfix_str(FIRST, refresh=False)
            yield StepBar(bar)
    finally:
        _LOOPS["open"] -= 1
        _LOOPS["finished"] += 1
