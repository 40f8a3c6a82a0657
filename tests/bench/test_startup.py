"""bench startup's table: medians over rounds and the goals it marks (issue 16)."""

import pytest

from crowdmotion.bench.startup import main, medians, table


def row(scene, cold, warm, bare, sim):
    return {"scene": scene, "cold_s": cold, "warm_s": warm, "bare_s": bare, "simulation_s": sim}


def test_each_column_is_the_median_over_the_rounds():
    rounds = [[row("a", 9.0, 3.0, 2.0, 1.0), row("b", 6.0, 2.0, 1.5, 0.1)],
              [row("a", 6.0, 2.0, 2.5, 1.2), row("b", 7.0, 2.5, 1.0, 0.2)],
              [row("a", 7.5, 2.6, 2.2, 0.9), row("b", 20.0, 2.1, 1.2, 0.3)]]
    got = medians(rounds)
    assert got == [{"scene": "a", "rounds": 3, "cold_s": 7.5, "warm_s": 2.6, "bare_s": 2.2, "simulation_s": 1.0},
                   {"scene": "b", "rounds": 3, "cold_s": 7.0, "warm_s": 2.1, "bare_s": 1.2, "simulation_s": 0.2}]


def test_the_table_marks_the_ratios_past_the_goals():
    lines = table([row("a", 7.5, 2.6, 2.2, 1.0), row("b", 7.0, 2.1, 1.2, 0.2)]).splitlines()
    assert lines[2] == "| a | 7.5 s | 2.6 s | 2.2 s | 1.00 s | 2.9x | 2.6x |"
    assert lines[3] == "| b | 7.0 s | 2.1 s | 1.2 s | 0.20 s | 3.3x (goal <= 3) | 10.5x (goal <= 3) |"


@pytest.mark.parametrize("argv, words", [(["--only", "no_such_scene"], "unknown built-in scene"),
                                         (["--rounds", "0"], "--rounds 0: must be at least 1")])
def test_bad_arguments_are_refused_before_anything_runs(argv, words, capsys):
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    assert words in capsys.readouterr().err
