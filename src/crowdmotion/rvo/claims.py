"""The personality paper's §6 observations (004), checked over many seeds.

Each claim compares two groups on one measure of :func:`crowdmotion.metrics.group_report`
(or one group against all others). Over seeds, a claim's verdict comes from the paired
per-seed difference (both poles walk in the same run) and its 95 % confidence interval
(Student's t): **holds** when the interval lies on the claimed side of 0, **contradicted**
when it lies on the other side, **not shown** when it contains 0.

>>> rows = check_claims([report_seed0, report_seed1, ...])           # doctest: +SKIP
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats


@dataclass(frozen=True)
class Claim:
    """``a`` ``op`` ``b`` on ``measure`` (op ">" or "<"); ``b == "*"``: against every other
    group of the runs (``a`` must beat the best of them)."""

    text: str
    measure: str
    a: str
    b: str
    op: str


CLAIMS = (
    Claim("O+ walks spread wider than O-", "lateral_spread_m", "O+", "O-", ">"),
    Claim("E+ walks spread wider than E-", "lateral_spread_m", "E+", "E-", ">"),
    Claim("C+ changes direction less than C-", "heading_change_rate_rad_s", "C+", "C-", "<"),
    Claim("C+ keeps closer to its straight line than C-", "lateral_deviation_m", "C+", "C-", "<"),
    Claim("A+ mixes into the other group more than A-", "mixing_index", "A+", "A-", ">"),
    Claim("A- forms more same-group clusters than A+", "clusters", "A-", "A+", ">"),
    Claim("A- walks in larger same-group clusters than A+", "cluster_size", "A-", "A+", ">"),
    Claim("N+ walks in a narrower band than N-", "lateral_spread_m", "N+", "N-", "<"),
    Claim("N+ walks in the narrowest band of all groups", "lateral_spread_m", "N+", "*", "<"),
)
DENSITY_CLAIM = "dense areas slow agents down (speed falls with local density)"


def mean_ci(values, level: float = 0.95) -> tuple[float, float, int]:
    """(mean, half-width of the ``level`` confidence interval by Student's t, n); the
    half-width is inf for fewer than two values."""
    x = np.asarray([v for v in values if v is not None], float)
    n = len(x)
    if n == 0:
        return float("nan"), float("inf"), 0
    if n < 2:
        return float(x[0]), float("inf"), 1
    half = float(stats.t.ppf(0.5 + level / 2, n - 1) * x.std(ddof=1) / np.sqrt(n))
    return float(x.mean()), half, n


def _verdict(mean: float, half: float, op: str) -> str:
    if not np.isfinite(half):  # one run: the sign alone
        half = 0.0
    lo, hi = mean - half, mean + half
    if op == "<":
        lo, hi = -hi, -lo
    return "holds" if lo > 0 else "contradicted" if hi < 0 else "not shown"


def check_claims(reports: list[dict], claims=CLAIMS, level: float = 0.95) -> list[dict]:
    """Every claim whose groups appear in the runs: per-group mean and CI, the paired
    difference a − b (for "*": a − the best other group in each run) with its CI, and
    the verdict. ``reports``: one :func:`~crowdmotion.metrics.group_report` per seed
    (runs may mix scenes: a claim uses the runs holding its groups)."""
    rows = []
    for c in claims:
        runs = [r for r in reports if c.a in r and (c.b == "*" or c.b in r)
                and r[c.a].get(c.measure) is not None]
        if not runs:
            continue
        a = [r[c.a][c.measure] for r in runs]
        if c.b == "*":
            pick = min if c.op == "<" else max
            b = [pick(v[c.measure] for g, v in r.items() if g != c.a and v.get(c.measure) is not None)
                 for r in runs]
        else:
            b = [r[c.b][c.measure] for r in runs]
        diff = mean_ci(np.subtract(a, b), level)
        rows.append({"claim": c.text, "measure": c.measure, "a": c.a, "b": c.b, "a_mean_ci": mean_ci(a, level),
                     "b_mean_ci": mean_ci(b, level), "difference_ci": diff,
                     "verdict": _verdict(diff[0], diff[1], c.op), "seeds": len(runs)})
    # one slope per run (its groups' mean): the runs are the independent samples, the
    # groups of one run are not
    per_run = [[v.get("speed_density_slope") for v in r.values()] for r in reports]
    slopes = [float(np.mean([s for s in run if s is not None])) for run in per_run if any(s is not None for s in run)]
    if slopes:
        m = mean_ci(slopes, level)
        rows.append({"claim": DENSITY_CLAIM, "measure": "speed_density_slope", "a": "all", "b": "0",
                     "a_mean_ci": m, "b_mean_ci": (0.0, 0.0, m[2]), "difference_ci": m,
                     "verdict": _verdict(m[0], m[1], "<"), "seeds": len(slopes),
                     "negative_share": float(np.mean(np.asarray(slopes) < 0))})
    return rows


def format_claims(rows: list[dict]) -> str:
    """A markdown table of :func:`check_claims`'s rows."""
    def ci(t):
        mean, half, _ = t
        return f"{mean:.3f} ± {half:.3f}" if np.isfinite(half) else f"{mean:.3f}"

    out = ["| observation (paper §6) | measure | first group | second group | difference (95 % CI) | seeds | verdict |",
           "|---|---|---|---|---|---|---|"]
    for r in rows:
        second = "0" if r["b"] == "0" else ("best other" if r["b"] == "*" else r["b"])
        out.append(f"| {r['claim']} | {r['measure']} | {r['a']} {ci(r['a_mean_ci'])} | {second} "
                   f"{ci(r['b_mean_ci']) if r['b'] != '0' else ''} | {ci(r['difference_ci'])} | {r['seeds']} | "
                   f"{r['verdict']} |")
    return "\n".join(out)
