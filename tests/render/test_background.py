"""The picture process: a forked child that draws a run's pictures (issue 16).

Each check runs in a fresh interpreter: pytest's workers run threads, and the picture
process (rightly) refuses to fork beside them."""

import os
import subprocess
import sys
import textwrap

import pytest

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux") or len(os.sched_getaffinity(0)) < 2,
                                reason="the picture process needs Linux and two cores")

PRELUDE = """
import os, signal, sys
from crowdmotion.render.background import PictureProcess
PARENT = os.getpid()

def where():
    return ["child" if os.getpid() != PARENT else "parent"]

def pid():
    return [os.getpid()]

def fail():
    raise ValueError("no such colour 'blurple'")

class Odd(Exception):
    def __init__(self):
        super().__init__("odd")
        self.hook = lambda: None  # does not pickle

def fail_oddly():
    raise Odd()

def die_in_child():
    if os.getpid() != PARENT:
        os.kill(os.getpid(), signal.SIGKILL)
    return ["parent"]

p = PictureProcess.start()
assert p is not None, "no picture process"
"""


def output_of(body: str) -> str:
    """What the script (after PRELUDE) prints, once it has exited 0."""
    done = subprocess.run([sys.executable, "-c", PRELUDE + textwrap.dedent(body)], capture_output=True, text=True,
                          timeout=60)
    assert done.returncode == 0, done.stderr
    return done.stdout.strip()


def test_the_job_runs_in_the_child():
    assert output_of("""
        p.submit(where, [()])
        print(*p.result())
    """) == "child"


def test_parts_are_drawn_side_by_side_and_come_back_in_order():
    assert output_of("""
        p.submit(pid, [(), (), ()])
        a, b, c = p.result()
        print(a == p.pid, b not in (p.pid, PARENT), c != PARENT)
    """).split() == ["True", "True", "True"]


def test_a_drawing_error_is_raised_in_the_parent_with_the_childs_traceback():
    assert output_of("""
        p.submit(fail, [()])
        try:
            p.result()
        except ValueError as exc:
            print(exc, "|", "drawn in the picture process" in "".join(exc.__notes__), "|",
                  "in fail" in "".join(exc.__notes__))
    """) == "no such colour 'blurple' | True | True"


def test_an_error_that_does_not_pickle_comes_back_as_its_text():
    assert output_of("""
        p.submit(fail_oddly, [()])
        try:
            p.result()
        except RuntimeError as exc:
            print(exc)
    """) == "Odd: odd"


def test_a_child_that_died_leaves_the_job_to_the_parent():
    assert output_of("""
        p.submit(die_in_child, [()])
        print(*p.result())
    """) == "parent"


def test_a_job_that_does_not_pickle_is_done_in_the_parent():
    assert output_of("""
        p.submit(lambda: where(), [()])
        print(*p.result())
    """) == "parent"


def test_a_child_given_nothing_leaves_when_closed():
    assert output_of("""
        pid = p.pid
        p.close()
        try:
            os.kill(pid, 0)
            print("still there")
        except ProcessLookupError:
            print("gone")
    """) == "gone"


def test_refused_when_turned_off_or_beside_other_threads():
    code = textwrap.dedent("""
        import threading, time
        from crowdmotion.render.background import PictureProcess
        print(PictureProcess.start() is None)
        t = threading.Thread(target=time.sleep, args=(1,)); t.start()
        import os; os.environ["CROWDMOTION_PICTURE_PROCESS"] = "1"
        print(PictureProcess.start() is None)
    """)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60,
                          env={**os.environ, "CROWDMOTION_PICTURE_PROCESS": "0"})
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["True", "True"]


def test_a_run_writes_the_same_files_with_and_without_it(tmp_path):
    folders = {}
    for flag in ("1", "0"):
        out = tmp_path / f"pp{flag}"
        done = subprocess.run([sys.executable, "-m", "crowdmotion", "run", "mdp_robots_2d", "-o", str(out), "-q"],
                              capture_output=True, text=True, timeout=300,
                              env={**os.environ, "CROWDMOTION_PICTURE_PROCESS": flag})
        assert done.returncode == 0, done.stderr
        folders[flag] = out
    names = sorted(p.name for p in folders["1"].iterdir())
    assert names == sorted(p.name for p in folders["0"].iterdir())
    assert {"paths.png", "values.png", "trajectories.parquet", "summary.json"} <= set(names)
    for name in names:
        assert (folders["1"] / name).read_bytes() == (folders["0"] / name).read_bytes(), name


def test_a_child_stopped_while_drawing_leaves_no_half_written_file(tmp_path):
    target = tmp_path / "paths.png"
    assert output_of(f"""
        import os
        import time
        from pathlib import Path
        from crowdmotion.io.atomic import atomic_path

        def slow_write():
            with atomic_path(Path({str(target)!r})) as tmp:
                tmp.write_text("half")
                time.sleep(30)
            return ["written"]

        p.submit(slow_write, [(), ()])
        time.sleep(1.0)
        p.close()  # what the run does when interrupted while the pictures are drawn
        try:
            os.kill(p.pid, 0)
            print("still there")
        except ProcessLookupError:
            print("stopped and reaped")
    """) == "stopped and reaped"
    # the write sleeps 30 s before it would land: an empty folder says close() stopped the
    # child mid-write instead of waiting for it (no clock needed)
    assert list(tmp_path.iterdir()) == []
