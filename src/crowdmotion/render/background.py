"""A run's pictures drawn in another process, whose plotting imports overlap the
simulation.

matplotlib takes about half a second to import and a run's pictures another 0.3-1 s to
draw, all on one core, after the simulation. ``crowdmotion run`` instead forks a
:class:`PictureProcess` before it simulates: the child imports the plotting stack on a
free core while the parent simulates, then draws the pictures from the run it is sent
(pickled through a pipe) while the parent writes the trajectories and summary.json. The
pictures come in parts (a formation's GIF apart from its other pictures): the child
forks a helper per part, up to one per core, which shares the imports already made.

Only on Linux (macOS's system libraries, its BLAS among them, are not safe to use in a
forked child, and the child draws with numpy), with more than one core, and while the
parent runs no other Python thread (a lock another thread held would stay held in the
child). The child ignores Ctrl-C (the parent decides what an interrupted run writes: a
run stopped while simulating still gets its pictures), is stopped by the parent when the
parent itself is stopped while the pictures are drawn, leaves when the parent closes the
pipe, and never returns into the parent's code (``os._exit``). A drawing error is raised
in the parent with the child's traceback; a child that died leaves the pictures to the
parent, drawn as without this module. ``CROWDMOTION_PICTURE_PROCESS=0`` turns it off.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
import traceback
from collections.abc import Callable
from multiprocessing.connection import Connection, Pipe
from pathlib import Path

from crowdmotion._precompile import can_fork, cores, fork, stop_children


GROUP_GONE_S = 2.0  # how long a stopped child's helpers get to be gone after SIGKILL


def _end_group(pgid: int) -> None:
    """SIGKILL what is left of process group ``pgid`` and wait (up to GROUP_GONE_S) until
    it is gone, so no helper of a stopped picture child writes a file after its parent
    has removed the run's files."""
    deadline = time.monotonic() + GROUP_GONE_S
    try:
        os.killpg(pgid, signal.SIGKILL)
        while time.monotonic() < deadline:
            time.sleep(0.01)
            os.killpg(pgid, 0)  # ProcessLookupError once the last member is reaped
    except OSError:
        pass


def _leave(signum, frame) -> None:
    raise SystemExit(128 + signum)  # unwinds: an atomic write in progress removes its temporary file


def _outcome(draw: Callable, args: tuple) -> tuple:
    """``("ok", draw(*args))``, or ``("error", exception, traceback text)``."""
    try:
        return ("ok", draw(*args))
    except SystemExit:  # stopped (SIGTERM): no more drawing
        raise
    except BaseException as exc:  # noqa: BLE001 - every failure goes back to the parent
        return ("error", exc, traceback.format_exc())


def _send(conn: Connection, reply: tuple) -> None:
    try:
        conn.send(reply)
    except Exception:  # noqa: BLE001 - an exception that does not pickle: its text
        conn.send(("error", RuntimeError(f"{type(reply[1]).__name__}: {reply[1]}"), reply[2]))


def _draw_parts(draw: Callable, parts: list[tuple]) -> tuple:
    """Every part drawn, side by side: a helper forked (the plotting stack already
    imported) for each part after the first, up to one per core, and the rest drawn
    here; the paths in part order, or the first part's error that failed."""
    helpers: dict[int, tuple[int, Connection]] = {}  # part -> (pid, pipe)
    if can_fork():
        for k in range(1, min(len(parts), cores())):
            theirs, ours = Pipe(duplex=False)
            pid = fork()
            if pid == 0:  # a helper: never returns
                try:
                    theirs.close()
                    _send(ours, _outcome(draw, parts[k]))
                finally:
                    os._exit(0)
            ours.close()
            helpers[k] = (pid, theirs)
    replies: list[tuple] = [None] * len(parts)
    try:
        for k, args in enumerate(parts):
            if k not in helpers:
                replies[k] = _outcome(draw, args)
        for k in list(helpers):
            pid, conn = helpers[k]
            try:
                replies[k] = conn.recv()
            except (EOFError, OSError):  # the helper died: its part is drawn here
                replies[k] = _outcome(draw, parts[k])
            conn.close()
            os.waitpid(pid, 0)
            del helpers[k]
    except BaseException:
        stop_children([pid for pid, _ in helpers.values()], signal.SIGTERM)
        raise
    for reply in replies:
        if reply[0] != "ok":
            return reply
    return ("ok", [path for reply in replies for path in reply[1]])


def _serve(conn: Connection) -> None:
    """The child: import the plotting stack, then draw the job it is sent."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _leave)
    try:
        import crowdmotion.render.plots  # noqa: F401  (matplotlib)
        import crowdmotion.render.player  # noqa: F401
    except Exception:  # noqa: BLE001 - the same error is raised, with its message, when drawing
        pass
    try:
        draw, parts = conn.recv()
    except (EOFError, OSError):  # the parent left (an error, or nothing to draw)
        return
    _send(conn, _draw_parts(draw, parts))


class PictureProcess:
    """A forked child that imports matplotlib now and draws a run's pictures later.

    >>> pictures = PictureProcess.start()            # None where it cannot help
    >>> # ... simulate ...
    >>> pictures.submit(draw_pictures, [args1, args2])   # doctest: +SKIP
    >>> paths = pictures.result()                    # doctest: +SKIP
    """

    def __init__(self, pid: int, conn: Connection):
        self.pid = pid
        self._conn = conn
        self._job: tuple | None = None
        self._sender: threading.Thread | None = None
        self._send_error: BaseException | None = None
        self._done = False
        self._closed = False

    @classmethod
    def start(cls) -> PictureProcess | None:
        """Fork the child, or None off Linux, on one core, or with other threads
        running (``CROWDMOTION_PICTURE_PROCESS=0`` also turns it off)."""
        if os.environ.get("CROWDMOTION_PICTURE_PROCESS", "1") == "0" or not sys.platform.startswith("linux"):
            return None
        if cores() < 2 or not can_fork():
            return None
        ours, theirs = Pipe()
        sys.stdout.flush()
        sys.stderr.flush()
        pid = fork()
        if pid == 0:  # the child: never returns
            code = 0
            try:
                os.setpgid(0, 0)  # its own process group, with the helpers it forks: stopped as one
                ours.close()
                _serve(theirs)
            except BaseException:  # noqa: BLE001
                code = 1
            finally:
                os._exit(code)
        theirs.close()
        return cls(pid, ours)

    def submit(self, draw: Callable[..., list[Path]], parts: list[tuple]) -> None:
        """Send ``draw(*args)`` for each ``args`` of ``parts`` to the child, which draws
        them side by side (from a thread: a large run takes a moment to pickle through
        the pipe while the parent writes its own files)."""
        self._job = (draw, list(parts))

        def send() -> None:
            try:
                self._conn.send(self._job)
            except BaseException as exc:  # noqa: BLE001 - result() draws here instead
                self._send_error = exc

        self._sender = threading.Thread(target=send, daemon=True)
        self._sender.start()

    def result(self) -> list[Path]:
        """Every part's paths, in part order, or the child's error raised here; where the
        child could not take the job (it died, or the job does not pickle), the parts are
        drawn in this process."""
        assert self._job is not None, "submit() first"
        self._sender.join()
        reply = None
        if self._send_error is None:
            try:
                reply = self._conn.recv()
            except (EOFError, OSError):
                reply = None
        self._done = True
        self.close()
        if reply is None:
            draw, parts = self._job
            return [path for args in parts for path in draw(*args)]
        if reply[0] == "ok":
            return reply[1]
        exc = reply[1]
        exc.add_note(f"(drawn in the picture process)\n{reply[2]}")
        raise exc

    def close(self) -> None:
        """Let the child go and reap it: it leaves on the closed pipe, or, still
        drawing (the parent was interrupted), on SIGTERM, removing a half-written file.
        Once only: a later call does nothing (the child's id may be another process's by then)."""
        if self._closed:
            return
        self._closed = True
        self._conn.close()
        if not self._done:
            stop_children([self.pid], signal.SIGTERM)
            _end_group(self.pid)  # helpers it had forked, left behind if it was killed
            return
        try:
            os.waitpid(self.pid, 0)
        except ChildProcessError:
            pass
