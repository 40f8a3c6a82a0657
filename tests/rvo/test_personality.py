"""OCEAN personalities: Table 4 exactly, eq. (4)'s directions, the generator, bad input."""

import numpy as np
import pytest

from crowdmotion import rvo
from crowdmotion.rvo.personality import blend, dominant_trait, sample_personalities, trig_generator

# Table 4 of the paper, typed in from the text (M, D, N_sample, w)
PAPER_TABLE4 = {
    "O+": (15, 15.0, 50, 3.0), "O-": (10, 5.0, 50, 7.5),
    "C+": (20, 20.0, 50, 1.0), "C-": (5, 5.0, 50, 7.5),
    "E+": (10, 10.0, 50, 4.0), "E-": (5, 5.0, 50, 6.0),
    "A+": (10, 10.0, 50, 7.5), "A-": (5, 5.0, 50, 3.0),
    "N+": (10, 2.5, 25, 3.0), "N-": (5, 5.0, 25, 7.5),
}

# eq. (4): +1 "grows with |ψk|", -1 "shrinks with |ψk|", for (M, D, w). For N− the paper
# prints "w ∝⁻¹ ψN" without the absolute value bars it uses elsewhere: with ψN < 0 that
# means w grows as ψN falls, i.e. with |ψN|, which is also what Table 4 (N− w = 7.5) needs.
EQ4 = {
    "O+": (1, 1, -1), "O-": (-1, -1, 1), "C+": (1, 1, -1), "C-": (-1, -1, 1),
    "E+": (1, 1, -1), "E-": (-1, -1, 1), "A+": (1, 1, 1), "A-": (-1, -1, -1),
    "N+": (1, -1, -1), "N-": (-1, 1, 1),
}


@pytest.mark.parametrize("pole", sorted(PAPER_TABLE4))
def test_pure_poles_give_table4_exactly(pole):
    m, d, s, w = PAPER_TABLE4[pole]
    expect = {"max_neighbors": m, "neighbor_dist": d, "samples": s, "safety": w}
    assert rvo.personality_params(pole) == expect
    vec = np.zeros(5)
    vec["OCEAN".index(pole[0])] = 1.0 if pole[1] == "+" else -1.0
    assert rvo.personality_params(vec) == expect
    assert rvo.personality_params(vec.tolist(), rule="max" if pole[1] == "+" else "abs") == expect


@pytest.mark.parametrize("pole", sorted(EQ4))
def test_intensity_moves_parameters_the_way_eq4_says(pole):
    weak, strong = blend(pole, 0.2), blend(pole, 0.9)
    for key, sign in zip(("max_neighbors", "neighbor_dist", "safety"), EQ4[pole]):
        if PAPER_TABLE4[pole] == PAPER_TABLE4[pole[0] + ("-" if pole[1] == "+" else "+")]:
            continue
        diff = strong[key] - weak[key]
        assert diff * sign >= 0, (pole, key, weak[key], strong[key])
    lo = blend(pole, 0.0)
    opp = pole[0] + ("-" if pole[1] == "+" else "+")
    assert lo["neighbor_dist"] == pytest.approx((PAPER_TABLE4[pole][1] + PAPER_TABLE4[opp][1]) / 2)


def test_dominant_trait_rules():
    psi = [0.1, -0.9, 0.3, 0.0, 0.0]
    assert dominant_trait(psi).pole == "C-" and dominant_trait(psi).intensity == pytest.approx(0.9)
    assert dominant_trait(psi, rule="max").pole == "E+"  # the paper's literal f(ψ) = max ψk
    half = rvo.personality_params([0, 0, 0, 0, 0.5])
    assert half["neighbor_dist"] == pytest.approx((3.75 + 2.5) / 2)


def test_trig_generator_spans_minus_one_to_one():
    th = np.linspace(-np.pi / 2, np.pi / 2, 101)
    psi = trig_generator(th)
    assert psi[0] == pytest.approx(-1) and psi[-1] == pytest.approx(1) and psi[50] == 0
    assert np.all(np.diff(psi) >= 0)
    assert np.allclose(np.abs(psi), 1 - np.cos(th))  # the paper's eq. (2) in magnitude


def test_distributions_are_seeded_and_in_range():
    spec = {"distribution": "trig", "theta_low": [0, 0, 0, 0, 0], "theta_high": [1.5, 0.5, 0.5, 0.5, 0.5]}
    a = sample_personalities(spec, 50, np.random.default_rng(4))
    b = sample_personalities(spec, 50, np.random.default_rng(4))
    assert a.shape == (50, 5) and np.array_equal(a, b) and a.min() >= 0 and a.max() <= 1
    n = sample_personalities({"distribution": "normal", "mean": [0.5] * 5, "std": [2.0] * 5}, 200,
                             np.random.default_rng(0))
    assert n.min() >= -1 and n.max() <= 1


@pytest.mark.parametrize("bad,words", [
    ("X+", "unknown personality trait 'X+'"),
    ([0, 0, 1.5, 0, 0], "ψE must lie in [-1, 1], got 1.5"),
    ([0, 0, 0], "must have 5 numbers"),
    ([0, float("nan"), 0, 0, 0], "ψC"),
    ({"distribution": "gamma"}, "distribution must be one of"),
    ({"distribution": "uniform", "low": [0] * 5}, "needs 'high'"),
])
def test_bad_personalities_name_the_problem(bad, words):
    with pytest.raises(ValueError) as e:
        sample_personalities(bad, 3, np.random.default_rng(0))
    assert words in str(e.value)


def test_a_crowd_without_personalities_writes_no_personality_rows_into_its_metadata():
    # a row of five nulls per agent went into every export's metadata (USD layer data,
    # JSON sidecars), growing with the crowd
    import crowdmotion as cm
    from crowdmotion import rvo

    plain = cm.Group("plain", 3, spawn=cm.Rect([0, 0], [4, 4]), goal=cm.Rect([8, 0], [10, 4]))
    scene = cm.Scene(bounds=([0, 0], [10, 4]))
    traj = rvo.simulate(scene, [plain], rvo.RVOParams(max_steps=4), np.random.default_rng(0))
    assert "personality" not in traj.metadata
    typed = cm.Group("typed", 2, spawn=cm.Rect([0, 0], [4, 4]), goal=cm.Rect([8, 0], [10, 4]),
                     attributes={"personality": "O+"})
    traj = rvo.simulate(scene, [plain, typed], rvo.RVOParams(max_steps=4), np.random.default_rng(0))
    rows = traj.metadata["personality"]
    assert len(rows) == 5 and all(np.isnan(v) for v in rows[0]) and rows[3][0] == 1.0
