"""Ctrl-C and SIGTERM as the ``crowdmotion`` command takes them.

SIGTERM (what ``timeout``, ``kill`` and batch schedulers send) is taken as Ctrl-C is:
the first stops the simulation, whose step loop keeps the frames so far (marked
partial) and the command writes them. Once the step loop has ended (the run measuring
its frames, then the command writing its files), a first interrupt waits for the
writing to finish (the files are left whole); a second stops at once, and the run's
files are then removed. The command exits with 128 plus the signal's number: 130 after
Ctrl-C, 143 after SIGTERM.

The command installs the handlers for its lifetime and restores the earlier ones after;
the library installs none (its step loops keep their frames on KeyboardInterrupt, as
Python raises it on Ctrl-C by default, through :func:`step_loop`).
"""

from __future__ import annotations

import signal
import sys
import threading
from contextlib import contextmanager
from typing import Iterator

NAMES = {signal.SIGINT: "Ctrl-C", signal.SIGTERM: "SIGTERM"}


def is_interrupt(exc: BaseException | None) -> bool:
    """Whether ``exc`` is Ctrl-C (or SIGTERM under :class:`Interrupts`): a KeyboardInterrupt,
    or the SystemError CPython raises from it when the interrupt lands as a compiled
    kernel returns ("CPUDispatcher(...) returned a result with an exception set")."""
    while isinstance(exc, SystemError):
        exc = exc.__cause__ or exc.__context__
    return isinstance(exc, KeyboardInterrupt)


class Stopped:
    """What :func:`step_loop` saw: ``stopped`` is True once an interrupt ended the loop."""

    stopped = False


@contextmanager
def step_loop() -> Iterator[Stopped]:
    """``with step_loop() as loop:`` around a simulation's step loop: an interrupt ends
    the block (``loop.stopped`` is then True) and the steps so far are kept; any other
    error goes on."""
    loop = Stopped()
    try:
        yield loop
    except (KeyboardInterrupt, SystemError) as exc:
        if not is_interrupt(exc):
            raise
        loop.stopped = True


class Interrupts:
    """The command's Ctrl-C and SIGTERM handlers, installed by ``with Interrupts() as
    stop:`` (in the main thread; elsewhere nothing is installed). ``stop.signum``: the
    first signal received, if any; ``stop.exit_code``: 128 plus its number."""

    def __init__(self) -> None:
        self.signum: int | None = None
        self.count = 0
        self._writing = False
        self._simulating: int | None = None  # step loops finished before the simulating block
        self._previous: dict[int, object] = {}

    @property
    def exit_code(self) -> int | None:
        return None if self.signum is None else 128 + self.signum

    @property
    def name(self) -> str:
        """The first signal as a user knows it (``Ctrl-C``, ``SIGTERM``)."""
        return NAMES.get(self.signum, f"signal {self.signum}") if self.signum is not None else ""

    def _handle(self, signum, frame) -> None:
        self.count += 1
        if self.signum is None:
            self.signum = signum
        if self.count == 1 and self._writing:
            self._say(f"{NAMES.get(signum, signum)}: finishing the files being written first ({self.again()})")
            return
        if self.count == 1 and self._after_steps():
            self._say(f"{NAMES.get(signum, signum)}: the simulation had finished; measuring it and writing its files "
                      f"first ({self.again()})")
            return
        raise KeyboardInterrupt

    def _after_steps(self) -> bool:
        """Inside :meth:`simulating`, with its step loop ended: the frames are all there."""
        if self._simulating is None:
            return False
        from crowdmotion.progress import step_loops

        under_way, finished = step_loops()
        return under_way == 0 and finished > self._simulating

    def again(self) -> str:
        """What a second interrupt does while the files are written, in a user's words."""
        return "Ctrl-C or SIGTERM again stops at once and keeps none of the run's files"

    @staticmethod
    def _say(text: str) -> None:
        try:
            print(f"crowdmotion: {text}", file=sys.stderr, flush=True)
        except (RuntimeError, OSError, ValueError):  # stderr busy (a handler inside its write) or closed
            pass

    @contextmanager
    def simulating(self) -> Iterator[None]:
        """A block that runs a simulation: a first interrupt in it stops the step loop
        (which keeps its frames so far), or, once the loop has ended, waits for the end
        of the block and of the writing after it."""
        from crowdmotion.progress import step_loops

        self._simulating = step_loops()[1]
        try:
            yield
        finally:
            self._simulating = None

    @contextmanager
    def writing(self) -> Iterator[None]:
        """A block that writes the run's files: a first interrupt in it waits for its end."""
        self._writing = True
        try:
            yield
        finally:
            self._writing = False

    def __enter__(self) -> Interrupts:
        if threading.current_thread() is threading.main_thread():
            for sig in NAMES:
                self._previous[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(self, *exc) -> None:
        for sig, previous in self._previous.items():
            signal.signal(sig, signal.SIG_DFL if previous is None else previous)
        self._previous.clear()
