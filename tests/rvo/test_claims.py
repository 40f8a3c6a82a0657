"""The personality paper's §6 claims over seeds: paired differences with 95 % intervals."""

import json

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from crowdmotion.cli import main
from crowdmotion.rvo.claims import Claim, check_claims, format_claims, mean_ci
from crowdmotion.trajectories import Trajectories


def test_mean_ci_is_students_t():
    mean, half, n = mean_ci([1, 2, 3, 4, 5])
    # t(0.975, 4) = 2.7764451 (tables); sd = sqrt(2.5)
    assert (mean, n) == (3.0, 5) and half == pytest.approx(2.7764451 * np.sqrt(2.5) / np.sqrt(5))
    assert mean_ci([4.0])[1] == float("inf") and mean_ci([])[2] == 0


def _runs(a_minus_b):
    return [{"X+": {"m": 1.0 + d, "speed_density_slope": -0.5}, "X-": {"m": 1.0, "speed_density_slope": -0.4},
             "Y+": {"m": 0.5, "speed_density_slope": None}} for d in a_minus_b]


@pytest.mark.parametrize("diffs,verdict", [([0.2, 0.3, 0.25, 0.28], "holds"), ([-0.2, -0.3, -0.25, -0.28], "contradicted"),
                                           ([0.3, -0.3, 0.1, -0.1], "not shown")])
def test_verdict_follows_the_paired_interval(diffs, verdict):
    rows = check_claims(_runs(diffs), claims=[Claim("X+ more than X-", "m", "X+", "X-", ">")])
    assert rows[0]["verdict"] == verdict and rows[0]["seeds"] == 4
    assert rows[0]["difference_ci"][0] == pytest.approx(np.mean(diffs))
    assert rows[-1]["claim"].startswith("dense areas") and rows[-1]["verdict"] == "holds"
    # one slope a run (its groups' mean): the groups of one run are not independent samples
    assert rows[-1]["seeds"] == 4 and rows[-1]["a_mean_ci"][0] == pytest.approx(-0.45)
    assert "| X+ more than X- | m |" in format_claims(rows)


def test_a_claim_against_all_others_takes_the_best_other_group_of_each_run():
    rows = check_claims(_runs([0.0, 0.0]), claims=[Claim("Y+ lowest", "m", "Y+", "*", "<")])
    assert rows[0]["b_mean_ci"][0] == 1.0 and rows[0]["verdict"] == "holds"  # 0.5 against min(1.0, 1.0)
    assert check_claims(_runs([0.1]), claims=[Claim("Z", "m", "Z+", "Z-", ">")])[:-1] == []  # groups absent


def test_report_on_a_sweep_folder_gives_intervals_and_claims(tmp_path, capsys):
    rng = np.random.default_rng(0)
    rows = []
    (tmp_path / "runs").mkdir()
    for seed in range(3):  # A+ wanders across the street, A- walks straight: two groups per run
        t = np.arange(40)[:, None]
        plus = np.stack([t * 0.5 + 0 * np.arange(5), 2 * np.sin(t / 4 + np.arange(5)) + np.arange(5)], -1)
        minus = np.stack([20 - t * 0.5 + 0 * np.arange(5), 6 + np.arange(5) + 0 * t], -1)
        pos = np.concatenate([plus, minus], axis=1) + rng.normal(0, 0.01, (40, 10, 2))
        f = tmp_path / "runs" / f"seed{seed}.parquet"
        Trajectories(pos, 0.25, group=np.array(["A+"] * 5 + ["A-"] * 5, object), radius=0.25).save(f)
        rows.append({"scenario": "t", "seed": seed, "file": str(f)})
    pq.write_table(pa.Table.from_pylist(rows), tmp_path / "sweep.parquet")
    assert main(["report", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "3 runs; mean ± half-width" in out and "A+ mixes into the other group more than A-" in out
    saved = json.loads((tmp_path / "report.json").read_text())
    assert saved["runs"] == 3 and set(saved["groups"]) == {"A+", "A-"} and len(saved["per_run"]) == 3


# docs/rvo.md, "The paper's §6 observations, measured": the verdicts over seeds 0-19
DOCUMENTED = {"O+ walks spread wider than O-": "holds", "E+ walks spread wider than E-": "holds",
              "C+ changes direction less than C-": "holds",
              "C+ keeps closer to its straight line than C-": "contradicted",
              "A+ mixes into the other group more than A-": "holds",
              "A- forms more same-group clusters than A+": "holds",
              "A- walks in larger same-group clusters than A+": "holds",
              "N+ walks in a narrower band than N-": "not shown",
              "N+ walks in the narrowest band of all groups": "contradicted"}


def _street_reports(seeds):
    from crowdmotion.cli import builtin_scenarios
    from crowdmotion.scenario import load_scenario, run_scenario

    paths = {p.stem: p for p in builtin_scenarios()}
    reports = [{} for _ in seeds]
    for trait in "OCEAN":
        sc = load_scenario(paths[f"rvo_street_{trait}"])
        for k, seed in enumerate(seeds):
            reports[k].update(run_scenario(sc, seed=seed, progress=False).summary["groups"])
    return reports


def test_each_street_scene_shows_the_claims_that_hold_with_its_default_seed():
    from crowdmotion.cli import builtin_scenarios
    from crowdmotion.scenario import load_scenario, run_scenario

    paths = {p.stem: p for p in builtin_scenarios()}
    merged = {}
    for trait in "OCEAN":
        merged.update(run_scenario(load_scenario(paths[f"rvo_street_{trait}"]), progress=False).summary["groups"])
    rows = {r["claim"]: r["verdict"] for r in check_claims([merged])}
    for claim, verdict in DOCUMENTED.items():
        if verdict == "holds":
            assert rows[claim] == "holds", claim
    assert rows["dense areas slow agents down (speed falls with local density)"] == "holds"


@pytest.mark.slow
def test_the_claims_over_twenty_seeds_are_as_documented():
    rows = {r["claim"]: r["verdict"] for r in check_claims(_street_reports(range(20)))}
    assert {c: rows[c] for c in DOCUMENTED} == DOCUMENTED
