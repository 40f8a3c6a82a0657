"""Progress bars for the methods' step loops: a total, and a clock that starts after the
first step, so loading (or, on a first run, compiling) the kernels does not make the ETA
read hours."""

from __future__ import annotations

import sys
import time
from contextlib import contextmanager
from typing import Iterator

from tqdm.auto import tqdm

FIRST = "first step: loading its kernels (compiled on a first run, then cached)"
# tqdm's monitor thread outlives the bars; with it alive a later run in this process
# could not compile its kernels on all cores (crowdmotion._precompile forks only a
# process without other threads). Our bars update every step: they need no monitor.
tqdm.monitor_interval = 0
LINE_EVERY_S = 10.0  # a log (output that is not a terminal) gets a progress line this often at most


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


class LineBar:
    """``StepBar``'s interface for output that is not a terminal (a log file, a pipe, a
    render farm's job log): a bar redrawn in place would leave a stale line there, so this
    writes a whole line at the first step reported (the kernels are loaded, the clock
    starts) and then at most every ``LINE_EVERY_S`` seconds. ``limit``: the total is an
    upper bound the loop may end before (a run's step limit), not a count of things."""

    def __init__(self, total: int | None, desc: str, unit: str, file, limit: bool = False,
                 clock_from_first: bool = True):
        self.total, self.desc, self.unit, self.file, self.limit = total, desc, unit, file, limit
        self.n = 0
        # a step loop's clock starts at its first step (its kernels loaded); a count of
        # scenes, cases or runs counts from the start, where "1/1 cases in 0 s" was a
        # case that took 19 s
        self.start: float | None = None if clock_from_first else time.monotonic()
        self.reported = False
        self.last = 0.0
        self.shown = -1  # the count the last line gave

    def done(self, n: int) -> None:
        now = time.monotonic()
        first = not self.reported
        if first:  # the first report (kernels loaded): a line says so
            self.reported = True
            self.start = now if self.start is None else self.start
            self.last = now
        self.n = n
        if first or now - self.last >= LINE_EVERY_S:
            self.last = now
            self.shown = self.n
            print(self.line(now), file=self.file, flush=True)

    def finish(self) -> None:
        """A last line with the final count, where the last line gave an earlier one (a log
        otherwise ends on "1/8 runs (12 %) in 0 s"); a loop that ended before its ``limit``
        (a run whose agents all arrived before its step limit) says it is done, where
        "860/2,000 steps (43 %)" read as a run that stopped."""
        if not self.reported:
            return
        now = time.monotonic()
        if self.limit and self.total and self.n < self.total:
            self.shown = self.n
            print(f"{self.desc}: done in {now - self.start:.0f} s after {self.n:,} of at most {self.total:,} "
                  f"{self.unit}s", file=self.file, flush=True)
        elif self.n != self.shown:
            self.shown = self.n
            print(self.line(now), file=self.file, flush=True)

    def advance(self, k: int = 1) -> None:
        self.done(self.n + k)

    update = advance  # tqdm's name, for the bars over scenes, cases and runs (:func:`counter`)

    def write(self, text: str, file=None) -> None:
        """A line of the caller's own (tqdm's ``write``): on a log it goes as it is."""
        print(text, file=self.file if file is None else file, flush=True)

    def line(self, now: float) -> str:
        """``rvo steps: 400/2,000 steps (20 %) in 12 s``"""
        of = "" if not self.total else f"/{self.total:,}"
        share = "" if not self.total else f" ({100 * self.n / self.total:.0f} %)"
        return f"{self.desc}: {self.n:,}{of} {self.unit}s{share} in {now - (self.start or now):.0f} s"


def _terminal(stream) -> bool:
    """Whether ``stream`` shows a bar redrawn in place: a terminal, or a notebook (whose
    tqdm draws a widget)."""
    from tqdm.autonotebook import tqdm as chosen  # the notebook's bar inside a notebook kernel

    if "notebook" in chosen.__module__:
        return True
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


@contextmanager
def counter(total: int | None, desc: str, unit: str, enabled: bool = True, leave: bool = False,
            file=None) -> Iterator:
    """A bar over ``total`` things done one by one (scenes, cases, runs, frames), with
    tqdm's ``update`` and ``write``: tqdm's bar on a terminal or in a notebook, a
    :class:`LineBar` on a log (on ``file``, default stderr), nothing when not ``enabled``."""
    stream = sys.stderr if file is None else file
    if enabled and not _terminal(stream):
        bar = LineBar(total, desc, unit, stream, clock_from_first=False)
        yield bar
        bar.finish()
        return
    with tqdm(total=total, desc=desc, unit=unit, disable=not enabled, leave=leave, file=file) as bar:
        yield bar


def tracked(items, desc: str, unit: str, total: int | None = None, enabled: bool = True):
    """``items`` one by one, counted by a :func:`counter`."""
    total = len(items) if total is None and hasattr(items, "__len__") else total
    with counter(total, desc, unit, enabled) as bar:
        for item in items:
            yield item
            bar.update(1)


# step loops (a method's run inside its step bar) under way and finished in this process
_LOOPS = {"open": 0, "finished": 0}


def step_loops() -> tuple[int, int]:
    """(step loops under way, step loops finished) in this process: the command tells from
    them whether a Ctrl-C stops a loop (which keeps its frames so far) or comes after one."""
    return _LOOPS["open"], _LOOPS["finished"]


@contextmanager
def step_bar(total: int | None, desc: str, enabled: bool = True, unit: str = "step",
             file=None) -> Iterator[StepBar | LineBar]:
    """A bar of ``total`` steps (shown after a second; on ``file``, default stderr) that
    says it is loading its kernels until the first step is reported; where ``file`` is
    not a terminal, a :class:`LineBar` instead. The method's step loop runs inside it
    (counted by :func:`step_loops`)."""
    _LOOPS["open"] += 1
    try:
        stream = sys.stderr if file is None else file
        if enabled and not _terminal(stream):
            line = LineBar(total, desc, unit, stream, limit=True)
            yield line
            line.finish()  # a log ends on the count the loop reached, not on its first step
            return
        with tqdm(total=total, desc=desc, unit=unit, disable=not enabled, delay=1.0, leave=False, file=file) as bar:
            bar.set_postfix_str(FIRST, refresh=False)
            yield StepBar(bar)
    finally:
        _LOOPS["open"] -= 1
        _LOOPS["finished"] += 1
