"""bench rvo's stand evacuation: the same stand, starts and speeds for every simulator,
everyone out, and overlaps counted the same way for all."""

import numpy as np
import pytest

from crowdmotion.bench import rvo as bench


def test_the_stand_keeps_its_walls_and_exits_at_any_head_count():
    scene, groups, params, seed = bench.stand_setup(30)
    assert groups[0].count == 30 and params.time_step == 0.25 and seed == 0
    boxes, doors, wall_y = bench._stand_walls(scene)
    assert len(boxes) == 4
    np.testing.assert_array_equal(doors, [10.0, 30.0, 50.0])
    assert wall_y == 13.0


def test_overlap_frames_counts_frames_with_two_bodies_present_overlapping():
    apart = np.array([[0.0, 0.0], [0.6, 0.0], [5.0, 5.0]])
    touching = np.array([[0.0, 0.0], [0.5, 0.0], [5.0, 5.0]])
    into = np.array([[0.0, 0.0], [0.45, 0.0], [5.0, 5.0]])
    everyone = np.ones(3, dtype=bool)
    gone = np.array([True, False, True])
    hit, deepest = bench.overlap_frames([apart, touching, into, into], [everyone, everyone, everyone, gone], 0.25)
    assert hit == 1 and deepest == pytest.approx(0.05)


def test_our_small_stand_evacuation_empties_without_overlaps():
    run = bench.ours_stand(40)
    assert run["out"] == 40 and run["overlap_frames"] == 0
    assert run["frames"] == run["steps"] + 1 and run["sim_s"] == pytest.approx(0.25 * run["steps"])


def test_pyrvo_walks_the_same_small_stand_out_through_the_exits():
    pytest.importorskip("pyrvo")
    run = bench.pyrvo_stand(40)
    assert run["out"] == 40
    assert 0 < run["core"] < run["wall"]


def test_jupedsim_walks_the_same_small_stand_out():
    pytest.importorskip("jupedsim")
    run = bench.jupedsim_stand(20)
    assert run["out"] == 20 and run["sim_s"] > 10


def test_side_by_side_times_both_simulators_on_the_same_open_scene():
    pytest.importorskip("pyrvo")
    pos, goal = bench.lattice(60, np.random.default_rng(0), "crossing")
    ours, core, full = bench.side_by_side(pos, goal, 3)
    assert ours > 0 and 0 < core < full


def test_the_step_parts_script_times_every_part_and_leaves_the_simulator_as_it_was(capsys):
    import runpy
    from pathlib import Path

    from crowdmotion.rvo import _kernels, simulator

    before = (simulator.Simulator._guidance, _kernels.choose_velocities)
    script = Path(__file__).parents[2] / "benchmarks" / "rvo_step_parts.py"
    runpy.run_path(str(script), run_name="parts")["main"](["--agents", "300", "--steps", "2"])
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("circle, 300 agents") and len(lines) == 13
    chosen = next(line for line in lines if "choosing velocities" in line)
    assert float(chosen.split()[-3]) > 0.0  # ms a step
    assert (simulator.Simulator._guidance, _kernels.choose_velocities) == before
