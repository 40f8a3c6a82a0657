"""Route stages as data: their checks, waiting times drawn from the seed, queue places."""

import numpy as np
import pytest

from crowdmotion.groups import Disc, Points, Rect
from crowdmotion.stages import Choose, GoTo, Leave, Queue, Wait, check_route, flat_stages, opening_width


def test_waiting_times_are_drawn_per_agent_the_same_for_the_same_key():
    agents = np.arange(2000)
    uniform = Wait({"uniform": [3.0, 8.0]}).durations(7, agents, 1)
    assert np.array_equal(uniform, Wait({"uniform": [3.0, 8.0]}).durations(7, agents, 1))
    assert uniform.min() >= 3.0 and uniform.max() < 8.0 and abs(uniform.mean() - 5.5) < 0.15
    assert not np.array_equal(uniform, Wait({"uniform": [3.0, 8.0]}).durations(8, agents, 1))
    normal = Wait({"normal": [20.0, 5.0]}).durations(7, agents, 1)
    assert abs(normal.mean() - 20.0) < 0.5 and abs(normal.std() - 5.0) < 0.4
    assert Wait({"normal": [1.0, 5.0]}).durations(7, agents, 1).min() == 0.0, "clipped at 0"
    assert Wait(5).durations(7, agents[:3], 1).tolist() == [5.0, 5.0, 5.0]


def test_queue_places_are_a_spacing_apart_along_the_line_and_straight_on_past_its_end():
    q = Queue(head=None, rate=1.0, line=[[10, 10], [10, 12], [8, 12]], spacing=0.5)
    places = q.slots(12)
    assert np.allclose(places[0], [10, 10]) and np.allclose(places[4], [10, 12]) and np.allclose(places[8], [8, 12])
    assert np.allclose(places[11], [6.5, 12]), "past the end it goes on straight"
    straight = Queue([30, 10], 0.5, direction=[-2, 0]).slots(3)
    assert np.allclose(straight, [[30, 10], [29.35, 10], [28.7, 10]])


@pytest.mark.parametrize("make,message", [
    (lambda: Queue([0, 0], 0.0, direction=[1, 0]), "queue.rate must be > 0"),
    (lambda: Queue([0, 0], 1.0), "give either direction"),
    (lambda: Wait(-1), "wait.time must be a number of seconds >= 0"),
    (lambda: Wait({"uniform": [5, 2]}), "low 5 exceeds high 2"),
    (lambda: GoTo(Points([[1, 1]]), arrive="free_point"), "needs a rect or disc area"),
    (lambda: Choose([Leave(Rect([0, 0], [1, 1]))]), "at least two stages"),
    (lambda: Choose([Wait(1), Leave(Rect([0, 0], [1, 1]))]), "choose.among.0 must be a goto, queue or leave"),
    (lambda: Choose([GoTo(Disc([0, 0], 1)), GoTo(Disc([5, 0], 1))], by="weights"), "weights go with"),
    (lambda: check_route([Leave(Rect([0, 0], [1, 1])), Wait(1)]), r"route.0 \(leave\).*must be the last stage"),
])
def test_a_bad_stage_is_refused_naming_what_is_wrong(make, message):
    with pytest.raises(ValueError, match=message):
        make()


def test_stage_ids_count_a_chooses_options_after_it():
    a, b = Leave(Rect([0, 0], [1, 1])), Leave(Rect([9, 0], [10, 1]))
    route = [GoTo(Disc([5, 5], 1)), Wait(2), Choose([a, b])]
    assert [(path, st.kind, top) for path, st, top in flat_stages(route)] == [
        ("route[0]", "goto", 0), ("route[1]", "wait", 1), ("route[2]", "choose", 2),
        ("route[2].among[0]", "leave", 2), ("route[2].among[1]", "leave", 2)]
    assert a.capacity == pytest.approx(1.3) and a.name == "exit rect [0, 0]-[1, 1]"


def test_an_exit_takes_in_1_3_persons_per_metre_of_the_passage_it_spans_by_default():
    assert Leave(Rect([9, 0], [11, 5])).capacity == pytest.approx(1.3 * 2.0), "a 2 m column below a door"
    assert Leave(Rect([0, 5], [0.5, 7])).capacity == pytest.approx(1.3 * 2.0), "a strip across a 2 m opening"
    assert GoTo(Disc([0, 0], 1.5)).capacity == pytest.approx(1.3 * 3.0)
    assert opening_width(Points([[1, 1]])) == 0.6 and opening_width(Rect([0, 0], [0.2, 0.3])) == 0.6
    assert Leave(Rect([0, 0], [1, 1]), capacity=0.5).capacity == 0.5, "a declared capacity wins"


@pytest.mark.parametrize("method", ["rvo", "mdp", "pso", "formation"])
def test_validate_and_each_method_agree_on_the_stages_it_follows(method):
    # validate reads each method's own list; the method's own route check refuses the rest
    import importlib

    from crowdmotion.scenario import ROUTE_SUPPORT

    exit_ = Leave(Rect([18, 0], [20, 4]))
    one = {"goto": [GoTo(Disc([5, 5], 1.0)), exit_], "wait": [Wait(1.0), exit_],
           "queue": [Queue([10, 5], rate=1.0, direction=[-1, 0]), exit_],
           "choose": [Choose([exit_, Leave(Rect([0, 0], [2, 4]))])], "leave": [exit_]}
    check = {"mdp": "check_mdp_route", "pso": "check_pso_route", "formation": "check_formation_route"}.get(method)
    follows = set()
    for kind, route in one.items():
        if check is None:  # RVO follows every stage: it has no refusal
            follows.add(kind)
            continue
        try:
            getattr(importlib.import_module(f"crowdmotion.{method}.routes"), check)(route, "here")
            follows.add(kind)
        except ValueError as exc:
            assert f"does not {kind}" in str(exc)
    assert follows == set(ROUTE_SUPPORT[method])
