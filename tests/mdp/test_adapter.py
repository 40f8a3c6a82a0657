"""The MDP run's pictures (mdp.adapter.write_plots)."""

import crowdmotion.render as render
from crowdmotion.builtin import builtin_scenarios
from crowdmotion.mdp import adapter
from crowdmotion.scenario import load_scenario, run_scenario


def test_the_value_field_of_a_scene_with_moving_obstacles_says_when_it_is_drawn(monkeypatch, tmp_path):
    # re-solved at every step: the last field is drawn, with the obstacles where they stood then
    titles = []
    monkeypatch.setattr(render, "plot_values", lambda values, path, *a, title="", **k: titles.append(title) or path)
    scenario = load_scenario(next(p for p in builtin_scenarios() if p.stem == "mdp_moving_obstacle"))
    result = run_scenario(scenario, progress=False)
    adapter.write_plots(scenario.scene, result.extras, tmp_path, ["values"], title="moving")
    end = result.trajectories.times[-1]
    assert titles == [f"moving: state values\nat the end, t = {end:.0f} s: moving obstacles where they stood then"]
