"""The papers' claims, checked against our runs: holds / does not hold, with the numbers, N/M counts
(points, or paired runs, where the claim holds) and bootstrap intervals where distributions are
compared. 002 Sec. VI: the gain policies on drops. 000 Secs. III-IV: reshaping's first impacts and
head forces on pushes. 004: the direction strategy's obstacle hits.

The IMU and torque claims are judged on the landing window (the first `metrics.LANDING_WINDOW` s after
impact, what 002 Fig. 6 shows); the whole-episode values, which often record the fall that follows,
are shown next to them. Drops with a swept baseline gain scale get one scope per scale.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import pandas as pd

from fallbench.report.grouping import with_robot
from fallbench.report.selection import among_objects, dropped, pushed
from fallbench.report.sensitivity import GAIN_SCALE, SWEEPS, sensitivity_runs, value_label
from fallbench.report.stats import bootstrap
from fallbench.report.style import ordered

STOP = 0.0  # rad: knee margin at or below this = the knee reached its mechanical stop
LANDING_COLUMNS = [
    "imu_peak_z_landing",
    "torque_demand_ratio_landing",
]  # NaN in stores written before they existed
CLAIMS = {  # key: (claim of 002 Sec. VI as the claims table words it, short label of the verdict matrix)
    "stiff_imu": ("stiff has the highest IMU acceleration (landing)", "stiff: highest IMU"),
    "stiff_knee": ("stiff stays off the knee stop", "stiff: off the stop"),
    "oneshot_knee": ("oneshot reaches the knee's mechanical stop", "oneshot: at the stop"),
    "zero_knee": ("zero reaches the knee's mechanical stop", "zero: at the stop"),
    "adaptive_imu": (
        "adaptive_qp has a lower IMU acceleration than stiff (landing)",
        "adaptive_qp: IMU < stiff",
    ),
    "adaptive_knee": ("adaptive_qp stays off the knee stop", "adaptive_qp: off the stop"),
    "adaptive_torque": (
        "adaptive_qp keeps torques under their limits (landing PD demand <= limit)",
        "adaptive_qp: demand <= limit",
    ),
}


def _count(holds: pd.Series) -> str:
    known = holds.dropna()
    return f"{int(known.astype(bool).sum())}/{len(known)}"


def _values(series: pd.Series, unit: str = "") -> str:
    return ", ".join(f"{p} {series[p]:.1f}" for p in ordered(series.index)) + unit


@dataclass(frozen=True)
class _DropStats:
    """A scope's drops per gain policy (Series) and per drop point x policy (DataFrames)."""

    imu: pd.Series  # median IMU z peak in the landing window, m/s^2
    imu_whole: pd.Series  # median IMU z peak over the whole episode, m/s^2
    knee: pd.Series  # min knee limit margin, rad
    demand: pd.Series  # median max PD demand / torque limit in the landing window
    demand_whole: pd.Series  # median max PD demand / torque limit over the episode
    applied: pd.Series  # max applied torque / limit
    imu_points: pd.DataFrame  # median landing IMU z peak per point, m/s^2
    knee_points: pd.DataFrame  # median knee limit margin per point, rad
    demand_points: pd.DataFrame  # median landing demand / limit per point


def _drop_stats(runs: pd.DataFrame) -> _DropStats:
    """The statistics 002's claims are judged on; a store without the landing columns gets NaN."""
    runs = runs.reindex(columns=runs.columns.union(LANDING_COLUMNS, sort=False))
    by = runs.groupby("policy")
    point = runs.point if "point" in runs else pd.Series("all", index=runs.index)
    per_point = {
        m: runs.assign(point=point).pivot_table(
            index="point", columns="policy", values=m, aggfunc="median", dropna=False
        )
        for m in ("imu_peak_z_landing", "knee_limit_margin", "torque_demand_ratio_landing")
    }
    return _DropStats(
        imu=by.imu_peak_z_landing.median(),
        imu_whole=by.imu_peak_z.median(),
        knee=by.knee_limit_margin.min(),
        demand=by.torque_demand_ratio_landing.median(),
        demand_whole=by.torque_demand_ratio_max.median(),
        applied=by.torque_ratio_max.max(),
        imu_points=per_point["imu_peak_z_landing"],
        knee_points=per_point["knee_limit_margin"],
        demand_points=per_point["torque_demand_ratio_landing"],
    )


class _Check(NamedTuple):
    key: str  # of CLAIMS
    holds: bool | None  # None: not decidable on these runs
    numbers: str
    points: pd.Series | None = None  # per drop point, whether the claim holds there (N/M)


def _imu_numbers(stats: _DropStats) -> str:
    return f"landing {_values(stats.imu)}; whole episode {_values(stats.imu_whole)} m/s^2 (median IMU z peak)"


def _knee_check(key: str, stats: _DropStats, policy: str, at_stop: bool) -> _Check:
    """`policy` reaches the knee's mechanical stop (`at_stop`) or stays off it."""
    margin = stats.knee[policy]
    points = stats.knee_points[policy]
    return _Check(
        key,
        bool(margin <= STOP) if at_stop else bool(margin > STOP),
        f"{policy} min knee margin {margin:+.3f} rad",
        points <= STOP if at_stop else points > STOP,
    )


def _stiff_imu_check(stats: _DropStats) -> _Check:
    highest = stats.imu_points.dropna(how="all")
    return _Check(
        "stiff_imu",
        None if stats.imu.isna().all() else bool(stats.imu.idxmax() == "stiff"),
        _imu_numbers(stats),
        highest.idxmax(axis=1) == "stiff" if len(highest) else None,
    )


def _adaptive_imu_check(stats: _DropStats) -> _Check:
    """adaptive_qp's landing IMU peak below stiff's, with the paired per-point difference."""
    adaptive, compared = stats.imu["adaptive_qp"], stats.imu.get("stiff", float("nan"))
    lower, difference = None, ""
    if "stiff" in stats.imu_points:
        paired = (stats.imu_points["adaptive_qp"] - stats.imu_points["stiff"]).dropna()
        lower = paired < 0
        difference = (
            f"; adaptive_qp - stiff per point, median [95 % CI]: {bootstrap(paired).format()} m/s^2"
            if len(paired)
            else ""
        )
    return _Check(
        "adaptive_imu",
        None if pd.isna(adaptive) or pd.isna(compared) else bool(adaptive < compared),
        _imu_numbers(stats) + difference,
        lower,
    )


def _adaptive_torque_check(stats: _DropStats) -> _Check:
    """adaptive_qp's landing PD demand within the torque limits (applied torques are clamped anyway)."""
    demand = stats.demand["adaptive_qp"]
    demand_points = stats.demand_points["adaptive_qp"].dropna()
    return _Check(
        "adaptive_torque",
        None if pd.isna(demand) else bool(demand <= 1.0),
        f"median max demand/limit {demand:.2f} in the landing (joints under the policy), "
        f"{stats.demand_whole['adaptive_qp']:.2f} over the episode (all joints); "
        f"applied torque max/limit {stats.applied['adaptive_qp']:.2f} (clamped by the motor)",
        demand_points <= 1.0 if len(demand_points) else None,
    )


def _checks(stats: _DropStats) -> list[_Check]:
    """002 Sec. VI's claims that the policies present in these drops can decide."""
    checks = []
    if {"stiff"} <= set(stats.imu.index):
        checks += [_stiff_imu_check(stats), _knee_check("stiff_knee", stats, "stiff", at_stop=False)]
    for policy in ("oneshot", "zero"):
        if policy in stats.knee.index:
            checks.append(_knee_check(f"{policy}_knee", stats, policy, at_stop=True))
    if "adaptive_qp" in stats.imu.index:
        checks += [
            _adaptive_imu_check(stats),
            _knee_check("adaptive_knee", stats, "adaptive_qp", at_stop=False),
            _adaptive_torque_check(stats),
        ]
    return checks


def _claims_for(runs: pd.DataFrame, scope: str) -> list[dict[str, str]]:
    """Rows of the claims table: 002 Sec. VI's claims on the drops `runs`, labelled `scope`."""
    return [
        {
            "scope": scope,
            "source": "002 Sec. VI",
            "claim": CLAIMS[check.key][0],
            "verdict": "n/a" if check.holds is None else ("holds" if check.holds else "does not hold"),
            "points holding": "" if check.points is None else _count(check.points),
            "numbers": check.numbers,
        }
        for check in _checks(_drop_stats(runs))
    ]


def _sensitivity_claims(runs: pd.DataFrame) -> list[dict[str, str]]:
    """One scope per setting of each sensitivity sweep and of adaptive_qp's swept parameters."""
    rows: list[dict[str, str]] = []
    for sweep in SWEEPS:
        swept = sensitivity_runs(runs, sweep)
        if swept.empty:
            continue
        settings = sorted(c for c in swept.columns if c.startswith("param:policy_params.adaptive_qp."))
        for value, group in swept.groupby("setting"):
            subsets = group.groupby(settings, dropna=False) if settings else [((), group)]
            for values, subset in subsets:
                values = values if isinstance(values, tuple) else (values,)
                setting = ", ".join(
                    f"{c.removeprefix('param:policy_params.')}={value_label(v)}"
                    for c, v in zip(settings, values)
                )
                scope = f"{'+'.join(sorted(subset.scenario.unique()))}: {sweep.scope} {value:g}"
                rows += _claims_for(subset, scope + (f", {setting}" if setting else ""))
    return rows


def _paired(runs: pd.DataFrame, column: str, strategy: str) -> pd.DataFrame:
    """`none` and `strategy` runs of the same point and policy, side by side."""
    key = ["point", "policy"] + (["robot"] if "robot" in runs else [])
    none = runs[runs.pre_impact == "none"].set_index(key)[column]
    other = runs[runs.pre_impact == strategy].set_index(key)[column]
    return pd.concat({"none": none, strategy: other}, axis=1).dropna()


def _share(runs: pd.DataFrame, column: str) -> str:
    values = runs[column].dropna().astype(float)
    return f"{int(values.sum())}/{len(values)} ({bootstrap(values, 'mean').format(2)})"


def prescription_claims(runs: pd.DataFrame) -> list[dict[str, str]]:
    """000's prescriptions on the pushes, `none` vs `reshape`; 004's obstacle avoidance with `direction`."""
    rows = []
    pushes = runs[(runs.status == "ok") & pushed(runs) & ~among_objects(runs)]  # pushes on open ground
    scope = f"pushes ({pushes.point.nunique()} points)"
    if {"none", "reshape"} <= set(pushes.pre_impact):
        none, reshape = pushes[pushes.pre_impact == "none"], pushes[pushes.pre_impact == "reshape"]
        for column, source, text in (
            (
                "first_impact_safe",
                "000 Sec. III",
                "reshape lands first on hands or feet more often than none",
            ),
            (
                "first_impact_prescribed",
                "000 Sec. IV",
                "reshape lands as 000 prescribes for its fall class more often than none",
            ),
        ):
            if column in pushes:
                holds = none[column].astype(float).mean() < reshape[column].astype(float).mean()
                rows.append(
                    {
                        "scope": scope,
                        "source": source,
                        "claim": text,
                        "verdict": "holds" if holds else "does not hold",
                        "points holding": "",
                        "numbers": f"runs where it happens: none {_share(none, column)}, reshape {_share(reshape, column)}",
                    }
                )
        paired = _paired(pushes, "contact_force_peak_head", "reshape")
        if len(paired):
            change = paired["reshape"] - paired["none"]
            rows.append(
                {
                    "scope": scope,
                    "source": "000 Sec. IV-B",
                    "claim": "reshape lowers the head's peak force",
                    "verdict": "holds" if change.median() < 0 else "does not hold",
                    "points holding": _count(change < 0),
                    "numbers": f"paired difference reshape - none (same point and policy), median [95 % CI]: {bootstrap(change).format()} N",
                }
            )
    obstacles = runs[(runs.status == "ok") & (runs.pre_impact.isin(["none", "direction"]))]
    if "obstacle_hit" in obstacles and {"none", "direction"} <= set(obstacles.pre_impact):
        paired = _paired(obstacles, "obstacle_hit", "direction").astype(float)
        holds = paired["direction"].mean() < paired["none"].mean()
        rows.append(
            {
                "scope": f"obstacle layouts ({len(paired)} paired runs)",
                "source": "004 Sec. V",
                "claim": "direction hits objects less often than none",
                "verdict": "holds" if holds else "does not hold",
                "points holding": _count(paired["direction"] < paired["none"]),
                "numbers": f"runs that hit an object: none {_share(paired, 'none')}, direction {_share(paired, 'direction')}",
            }
        )
    return rows


def claims_table(runs: pd.DataFrame) -> pd.DataFrame:
    """Claims over the single 1 m drop, over every drop run of the sweep (default gains), and per
    baseline gain scale of a sensitivity sweep; per robot."""
    runs = with_robot(runs)
    drops = runs[(runs.status == "ok") & dropped(runs) & (runs.pre_impact == "none")]
    if GAIN_SCALE in drops:
        drops = drops[drops[GAIN_SCALE].fillna(1.0) == 1.0]
    rows: list[dict[str, str]] = []
    height = "param:initial.height"
    for robot, robot_runs in runs.groupby("robot"):
        robot_drops = drops[drops.robot == robot]
        scoped: list[dict[str, str]] = []
        if height in robot_drops.columns:
            one_metre = robot_drops[robot_drops[height] == 1.0]
            if len(one_metre):
                scoped += _claims_for(one_metre, "1 m drop")
        if len(robot_drops):
            scoped += _claims_for(
                robot_drops,
                f"all drops ({robot_drops.point.nunique() if 'point' in robot_drops else 1} points)",
            )
        scoped += _sensitivity_claims(robot_runs)
        scoped += prescription_claims(robot_runs) if "point" in robot_runs else []
        rows += [{"robot": robot, **row} for row in scoped]
    return pd.DataFrame(rows)


def verdict_matrix(claims: pd.DataFrame) -> pd.DataFrame:
    """The claims table at a glance: one row per (robot, scope), one column per claim, its verdict."""
    if claims.empty:
        return claims
    labels = {text: label for text, label in CLAIMS.values()}
    rows = claims[claims["claim"].isin(labels)]
    if rows.empty:
        return rows
    matrix = rows.assign(claim=rows["claim"].map(labels)).pivot_table(
        index=["robot", "scope"], columns="claim", values="verdict", aggfunc="first", sort=False
    )
    return matrix[[label for label in labels.values() if label in matrix.columns]].reset_index()


def robust_claims(claims: pd.DataFrame, halved: pd.DataFrame) -> pd.DataFrame:
    """The claims table with each verdict at half the step and whether it is the same (robust)."""
    if halved.empty or claims.empty:
        return claims
    at_half = claims_table(halved)
    if at_half.empty:
        return claims
    half = at_half.set_index(["robot", "scope", "claim"])["verdict"]
    keys = list(zip(claims.robot, claims.scope, claims.claim))
    verdicts = [half.get(key, "-") for key in keys]
    robust = ["yes" if v == old else ("-" if v == "-" else "no") for v, old in zip(verdicts, claims.verdict)]
    return claims.assign(**{"verdict at half the step": verdicts, "robust": robust})
