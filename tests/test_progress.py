"""Progress bars: a total, 'loading its kernels' until the first step, a clock from there."""

import io

from crowdmotion.progress import FIRST, step_bar
from crowdmotion.pso.adapter import expected_steps
from crowdmotion.scenario import load_scenario
from crowdmotion.cli import builtin_scenarios


def test_the_bar_says_compiling_until_the_first_step_then_counts_from_it():
    out = io.StringIO()
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
