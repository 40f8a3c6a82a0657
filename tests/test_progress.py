"""Progress bars: a total, 'loading its kernels' until the first step, a clock from there."""

import io
from types import SimpleNamespace

import pytest

from crowdmotion import progress
from crowdmotion.progress import FIRST, LineBar, step_bar
from crowdmotion.pso.simulation import expected_steps
from crowdmotion.scenario import load_scenario
from crowdmotion.cli import builtin_scenarios


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_the_bar_says_compiling_until_the_first_step_then_counts_from_it():
    out = Terminal()
    with step_bar(200, "rvo steps", file=out) as bar:
        assert FIRST in bar.bar.postfix
        bar.done(10)  # the first chunk, compile included: the clock restarts here
        assert bar.bar.n == bar.bar.initial == 10 and not bar.bar.postfix
        bar.done(30)
        bar.advance(5)
        assert bar.bar.n == 35 and bar.bar.total == 200


def test_pso_bars_have_a_total():
    scenes = {p.stem: p for p in builtin_scenarios()}
    gathering = load_scenario(scenes["pso_gathering"])
    assert expected_steps(gathering.groups, gathering.params) == gathering.params.iterations
    following = load_scenario(scenes["pso_following"])
    assert expected_steps(following.groups, following.params) > following.params.iterations


def test_a_log_gets_whole_lines_now_and_then_not_a_bar_redrawn_in_place(monkeypatch):
    clock = {"t": 100.0}
    monkeypatch.setattr(progress.time, "monotonic", lambda: clock["t"])
    log = io.StringIO()  # a file or a pipe: not a terminal
    with step_bar(2000, "rvo steps", file=log) as bar:
        assert isinstance(bar, LineBar)
        bar.done(10)  # the first step (kernels loaded): the clock starts, and a line says so
        assert log.getvalue() == "rvo steps: 10/2,000 steps (0 %) in 0 s\n"
        clock["t"] += 4.0
        bar.done(200)  # under LINE_EVERY_S since the last line: nothing
        clock["t"] += progress.LINE_EVERY_S
        bar.advance(200)
    assert log.getvalue().splitlines()[1:] == ["rvo steps: 400/2,000 steps (20 %) in 14 s",
                                               "rvo steps: done in 14 s after 400 of at most 2,000 steps"]
    assert "\r" not in log.getvalue()


def test_a_log_ends_on_the_count_the_run_reached_and_says_it_is_done(monkeypatch):
    clock = {"t": 100.0}
    monkeypatch.setattr(progress.time, "monotonic", lambda: clock["t"])
    log = io.StringIO()
    with step_bar(2000, "rvo steps", file=log) as bar:
        bar.done(10)
        clock["t"] += 3.0
        bar.done(860)  # everyone arrived: the run ends before its step limit, within LINE_EVERY_S
    assert log.getvalue().splitlines() == ["rvo steps: 10/2,000 steps (0 %) in 0 s",
                                           "rvo steps: done in 3 s after 860 of at most 2,000 steps"]
    log = io.StringIO()
    with step_bar(20, "rvo steps", file=log) as bar:  # to its limit: the count as ever
        bar.done(1)
        clock["t"] += 2.0
        bar.done(20)
    assert log.getvalue().splitlines()[-1] == "rvo steps: 20/20 steps (100 %) in 2 s"


def test_a_disabled_bar_writes_nothing():
    log = io.StringIO()
    with step_bar(10, "rvo steps", enabled=False, file=log) as bar:
        bar.done(5)
    assert log.getvalue() == ""


def test_bars_over_scenes_and_runs_write_lines_to_a_log(monkeypatch):
    from crowdmotion.progress import counter, tracked

    monkeypatch.setattr(progress, "time", SimpleNamespace(monotonic=lambda: 100.0))  # no clock: the line says 0 s
    log = io.StringIO()
    with counter(3, "demo", "scene", file=log) as bar:
        bar.write("rvo_doorway: 120 agents", file=log)  # a line of the caller's own, as it is
        bar.update(1)  # the first: the clock starts, and a line says so
    assert log.getvalue().splitlines() == ["rvo_doorway: 120 agents", "demo: 1/3 scenes (33 %) in 0 s"]
    assert list(tracked([1, 2, 3], "report runs", "run", enabled=False)) == [1, 2, 3]


def test_a_log_ends_on_the_final_count_not_the_first(monkeypatch):
    from crowdmotion.progress import counter

    monkeypatch.setattr(progress, "time", SimpleNamespace(monotonic=lambda: 100.0))  # no clock: the lines say 0 s
    log = io.StringIO()
    with counter(8, "sweep runs", "run", file=log) as bar:
        for _ in range(8):
            bar.update(1)
    assert log.getvalue().splitlines() == ["sweep runs: 1/8 runs (12 %) in 0 s", "sweep runs: 8/8 runs (100 %) in 0 s"]


def test_a_count_of_cases_on_a_log_counts_its_time_from_the_start(monkeypatch):
    # the first case done after 19 s read "1/1 cases (100 %) in 0 s": a count of scenes,
    # cases or runs has no kernels to load before its clock starts, as a step loop does
    from crowdmotion.progress import counter

    clock = [100.0]
    monkeypatch.setattr(progress, "time", SimpleNamespace(monotonic=lambda: clock[0]))
    log = io.StringIO()
    with counter(1, "verify", "case", file=log) as bar:
        clock[0] += 19.0
        bar.update(1)
    assert log.getvalue().splitlines() == ["verify: 1/1 cases (100 %) in 19 s"]
    log = io.StringIO()
    with step_bar(10, "rvo steps", file=log) as steps:  # a step loop: from its first step
        clock[0] += 5.0
        steps.done(1)
        clock[0] += 2.0
        steps.done(10)
    assert log.getvalue().splitlines()[0] == "rvo steps: 1/10 steps (10 %) in 0 s"
    assert log.getvalue().splitlines()[-1] == "rvo steps: 10/10 steps (100 %) in 2 s"


def _small_run(method):
    """(simulate, scene, groups, params) of a few steps of ``method``."""
    import crowdmotion as cm
    from crowdmotion import formation, mdp, pso, rvo

    scene = cm.Scene(bounds=([0, 0], [12, 6]))
    group = cm.Group("g", 3, spawn=cm.Rect([1, 1], [3, 5]), goal=cm.Rect([9, 1], [11, 5]), radius=0.25)
    if method == "mdp":
        return mdp.simulate, scene, [group], mdp.MDPParams(max_steps=6, smoothing=None)
    if method == "rvo":
        return rvo.simulate, scene, [group], rvo.RVOParams(max_steps=6)
    if method == "pso":
        return pso.simulate, scene, [group], pso.PSOParams(iterations=6, v_max=[0.25, 0.25], smoothing="linear")
    block = cm.Group("block", 4, cm.Points([[2.0, 3.0]]), (10.0, 3.0), radius=0.25,
                     attributes={"formation": {"kind": "block", "rows": 2, "cols": 2, "spacing": 1.0}})
    return formation.simulate, scene, [block], {"max_steps": 6, "fps": None}


@pytest.mark.parametrize("method", ["mdp", "rvo", "pso", "formation"])
def test_every_method_s_simulate_shows_the_command_s_progress_when_asked_and_nothing_by_default(method, capsys):
    # mdp.simulate said nothing while its kernels compiled (about 10 s on a first run), and
    # no method's simulate could show the bar the command and crowdmotion.run show
    import numpy as np

    simulate, scene, groups, params = _small_run(method)
    simulate(scene, groups, params, np.random.default_rng(0))
    assert capsys.readouterr().err == ""
    simulate(scene, groups, params, np.random.default_rng(0), progress=True)
    err = capsys.readouterr().err  # not a terminal here: the command's progress lines
    desc = {"mdp": "mdp steps", "rvo": "rvo steps", "pso": "pso", "formation": "formation steps"}[method]
    assert err.startswith(f"{desc}: ") and ("/6 " in err or "of at most 6 " in err), err
