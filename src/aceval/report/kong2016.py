"""Kong et al. 2016 Tables 3-11 from the tidy objective tables, with the published value beside
every reproduced one (``reference/kong2016``, see its SOURCE.md).

Each builder returns one tidy frame: key columns, this run's values, ``n`` (what is counted is
stated in the table's entry of :mod:`aceval.report.outputs`), ``published_*`` and
``difference``. :func:`to_markdown` renders it in the paper's layout plus a long comparison table.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from aceval.calibrate.table import unflagged
from aceval.evaluation.objectives import SEGMENT_ORDER
from aceval.report.set_tests import SET_TESTS, ttest_table

REFERENCE = Path(__file__).parent / "reference" / "kong2016"

#: layout of each Kong table (titles, objective and unit: :mod:`aceval.report.outputs`)
TABLES = {
    3: dict(
        reference="table3_frontal_lateral_correlation",
        row="t_ap",
        column="segment",
        kind="correlation",
    ),
    4: dict(
        reference="table4_box_acc_correlation",
        row="t_ap",
        column="imu",
        kind="correlation",
    ),
    5: dict(
        reference="table5_box_gyro_correlation",
        row="t_ap",
        column="imu",
        kind="correlation",
    ),
    6: dict(
        reference="table6_segment_pair_correlation",
        row="pair",
        column="t_ap",
        kind="correlation",
    ),
    7: dict(
        reference="table7_ttest_segment_pair_correlation",
        kind_of_value="correlation",
        row="pair",
        kind="ttest",
    ),
    8: dict(
        reference="table8_ttest_incremental_angle",
        kind_of_value="angle",
        row="segment",
        kind="ttest",
    ),
    9: dict(
        reference="table9_test_retest_angle",
        row="t_ex",
        column="segment",
        kind="angle",
        flag_above=1.0,
    ),
    10: dict(
        reference="table10_ttest_test_retest_angle",
        kind_of_value="angle",
        row="segment",
        kind="ttest",
    ),
    11: dict(
        reference="table11_cross_test_angle",
        row="t_ex_pair",
        column="segment",
        kind="angle",
        flag_above=5.0,
    ),
}
CORRELATION_FLAG = 0.95  # Kong's grey cells: correlation <= 0.95
#: a heading error is "detected" by Obj 1's correlation when at least this share of the units
#: falls below the 5th percentile of the correct calibrations of their cell
DETECTED_SHARE = 0.5


def reference(number: int) -> pd.DataFrame:
    """The published Kong table ``number`` (reference/kong2016)."""
    return pd.read_csv(REFERENCE / f"{TABLES[number]['reference']}.csv", comment="#")


def rename_tests(values: pd.Series, paper_names: dict[str, str]) -> pd.Series:
    """Test names as the paper calls them (``paper_names`` maps the dataset's names; 'A-B' pairs
    are renamed part by part).
    """
    return values.astype(str).map(
        lambda v: "-".join(paper_names.get(part, part) for part in v.split("-"))
    )


def _summary(values: pd.DataFrame, keys: list[str], value: str) -> pd.DataFrame:
    """Mean, SD (ddof 1) and count of ``value`` per ``keys``."""
    return values.groupby(keys)[value].agg(mean="mean", sd="std", n="count").reset_index()


def _compare(
    result: pd.DataFrame, published: pd.DataFrame, keys: list[str], columns: list[str]
) -> pd.DataFrame:
    """Outer-join this run with the paper's ``columns`` (as ``published_*``) on ``keys``, and add
    ``difference`` = mean - published mean.
    """
    published = published[keys + columns].rename(columns={c: f"published_{c}" for c in columns})
    merged = result.merge(published, on=keys, how="outer")
    merged["difference"] = merged["mean"] - merged["published_mean"]
    return merged


# --- correlation tables (3-6) -----------------------------------------------------------------


def _frontal_lateral_units(correlations: pd.DataFrame, signal: str) -> pd.DataFrame:
    table = correlations[
        (correlations["objective"] == "frontal_lateral")
        & (correlations["signal"] == signal)
        & unflagged(correlations)
    ]
    return table.groupby(["subject", "imu", "segment", "t_ex", "t_ap"], as_index=False)[
        "correlation"
    ].mean()


def table3(correlations: pd.DataFrame, paper_names: dict) -> pd.DataFrame:
    """Kong Table 3: frontal vs lateral acceleration correlation per T_ap and segment."""
    units = _frontal_lateral_units(correlations, "acc")
    units["t_ap"] = rename_tests(units["t_ap"], paper_names)
    result = _summary(units, ["t_ap", "segment"], "correlation")
    return _flag_low(_compare(result, reference(3), ["t_ap", "segment"], ["mean", "sd"]))


def box_table(number: int, correlations: pd.DataFrame, paper_names: dict) -> pd.DataFrame:
    """Tables 4 (acc) and 5 (gyro): per T_ap and IMU position, averaged over repetitions."""
    units = _frontal_lateral_units(correlations, "acc" if number == 4 else "gyr")
    units["t_ap"] = rename_tests(units["t_ap"], paper_names)
    result = _summary(units, ["t_ap", "imu"], "correlation")
    published = reference(number).melt(id_vars="t_ap", var_name="imu", value_name="mean")
    return _flag_low(_compare(result, published, ["t_ap", "imu"], ["mean"]))


def table6(correlations: pd.DataFrame, paper_names: dict) -> pd.DataFrame:
    """Kong Table 6: correlation of segments moved as one rigid body, per pair and T_ap."""
    table = correlations[(correlations["objective"] == "segment_pair") & unflagged(correlations)]
    units = table.groupby(
        ["subject", "sensor_set", "side", "pair", "t_ex", "t_ap"], as_index=False
    )["correlation"].mean()
    units["t_ap"] = rename_tests(units["t_ap"], paper_names)
    result = _summary(units, ["pair", "t_ap"], "correlation")
    return _flag_low(_compare(result, reference(6), ["pair", "t_ap"], ["mean", "sd"]))


#: the terms of the Obj 1-2 factor models: T_ex, T_ap, segment (Obj 2: pair) and the T_ap x
#: segment (pair) interaction, which the additive model left in its residual
FACTOR_MODELS = {
    "Obj 1": (["t_ex", "t_ap", "segment"], [("t_ap", "segment")]),
    "Obj 2": (["t_ex", "t_ap", "pair"], [("t_ap", "pair")]),
}


def correlation_factors(correlations: pd.DataFrame | None) -> pd.DataFrame:
    """Kong Obj 1-2, "not related with T_ex but highly related with T_ap and body segment": the
    share of variance of the correlations of Table 3's units (T_ex, T_ap, segment and T_ap x
    segment) and Table 6's (T_ex, T_ap, pair and T_ap x pair)
    (:func:`aceval.evaluation.stats.variance_shares`): pooled type II eta squared, each factor's
    share with its interaction (``involved``), and over the subjects the mean of each subject's
    own share (chance removed: epsilon squared) with its 95 % t-interval.
    """
    from aceval.evaluation.stats import variance_shares

    columns = [
        "objective",
        "factor",
        "eta_squared",
        "involved",
        "subject_mean",
        "low",
        "high",
        "aliased",
        "n",
        "n_subjects",
    ]
    if correlations is None or correlations.empty:
        return pd.DataFrame(columns=columns)
    obj1 = _frontal_lateral_units(correlations, "acc")
    pairs = correlations[(correlations["objective"] == "segment_pair") & unflagged(correlations)]
    obj2 = pairs.groupby(["subject", "sensor_set", "side", "pair", "t_ex", "t_ap"], as_index=False)[
        "correlation"
    ].mean()
    tables = [
        variance_shares(units, "correlation", *FACTOR_MODELS[objective]).assign(objective=objective)
        for objective, units in (("Obj 1", obj1), ("Obj 2", obj2))
        if not units.empty
    ]
    return (
        pd.concat(tables, ignore_index=True)[columns] if tables else pd.DataFrame(columns=columns)
    )


def correlation_sensitivity(correlations: pd.DataFrame | None) -> pd.DataFrame:
    """How the Obj 1 acceleration correlation falls when the second set's calibration is turned by
    a known heading error about body z, per correlation mode: mean, SD and n over Table 3's units
    (subject x IMU x T_ex x T_ap, each averaged over the repetitions), the drop from no error, and
    that drop in units of the SD between units at no error (``drop_over_sd``: the error is visible
    against the spread of correct calibrations when it is well above 1), and the share of units
    whose correlation falls below the 5th percentile of the correct calibrations of their own
    cell (mode, segment and T_ap, as Table 3 reads them: ``detected_share``, about 0.05 by chance);
    ``detection_threshold_deg``: per mode, the smallest heading error detected in at least half
    of the units (:data:`DETECTED_SHARE`; NaN when none is): the one number SUMMARY.md and the
    docs quote as what Obj 1 can detect.
    """
    columns = [
        "mode",
        "heading_error_deg",
        "mean",
        "sd",
        "n",
        "drop",
        "drop_over_sd",
        "detected_share",
        "detection_threshold_deg",
    ]
    if correlations is None or correlations.empty:
        return pd.DataFrame(columns=columns)
    keys = ["subject", "imu", "segment", "t_ex", "t_ap", "mode", "heading_error_deg"]
    chosen = (correlations["objective"] == "frontal_lateral_sensitivity") & unflagged(correlations)
    data = correlations.loc[chosen, [*keys, "correlation"]]  # not copies of the other columns
    units = data.groupby(keys, as_index=False)["correlation"].mean()
    if units.empty:  # one sensor set: no sensitivity rows
        return pd.DataFrame(columns=columns)
    table = _summary(units, ["mode", "heading_error_deg"], "correlation")
    at_zero = table[table["heading_error_deg"] == 0].set_index("mode")
    table["drop"] = table["mode"].map(at_zero["mean"]) - table["mean"]
    table["drop_over_sd"] = table["drop"] / table["mode"].map(at_zero["sd"])
    cell = ["mode", "segment", "t_ap"]
    correct = (
        units[units["heading_error_deg"] == 0].groupby(cell)["correlation"].quantile(0.05)
    ).rename("reference")
    units = units.merge(correct.reset_index(), on=cell, how="left")
    units["detected"] = units["correlation"] < units["reference"]
    detected = units.groupby(["mode", "heading_error_deg"])["detected"].mean()
    table = table.merge(detected.rename("detected_share").reset_index(), how="left")
    half = table[table["detected_share"] >= DETECTED_SHARE]
    threshold = half.groupby("mode")["heading_error_deg"].min()
    table["detection_threshold_deg"] = table["mode"].map(threshold)
    return table[columns]


def _flag_low(table: pd.DataFrame) -> pd.DataFrame:
    table["flag"] = np.where(table["mean"] <= CORRELATION_FLAG, "<=0.95", "")
    table["published_flag"] = np.where(table["published_mean"] <= CORRELATION_FLAG, "<=0.95", "")
    return table


# --- angle tables (9, 11) ---------------------------------------------------------------------


def angle_table(number: int, angles: pd.DataFrame, paper_names: dict) -> pd.DataFrame:
    """Kong Table 9 (test-retest) or 11 (cross-test): error angle per row and segment."""
    comparison, row = ("test_retest", "t_ex") if number == 9 else ("cross_test", "t_ex_pair")
    table = angles[angles["comparison"] == comparison].copy()
    table[row] = rename_tests(table["test"], paper_names)
    result = _summary(table, [row, "segment"], "error_angle_deg")
    published = reference(number).rename(columns={"mean_deg": "mean", "sd_deg": "sd"})
    merged = _compare(result, published, [row, "segment"], ["mean", "sd"])
    limit = TABLES[number]["flag_above"]
    merged["flag"] = np.where(merged["mean"] > limit, f">{limit:g} deg", "")
    merged["published_flag"] = np.where(merged["published_mean"] > limit, f">{limit:g} deg", "")
    return merged


# --- paired t-tests (7, 8, 10) ----------------------------------------------------------------


# --- one entry point --------------------------------------------------------------------------


def build(
    number: int,
    correlations: pd.DataFrame | None,
    angles: pd.DataFrame | None,
    sensor_sets: list[str],
    paper_names: dict | None = None,
) -> pd.DataFrame:
    """Kong Table ``number`` (3-11) as a tidy frame, rows in the paper's order, values rounded
    (correlations and angles to 4 decimals, p to 3 significant digits).
    """
    names = paper_names or {}
    if number == 3:
        table = table3(correlations, names)
    elif number in (4, 5):
        table = box_table(number, correlations, names)
    elif number == 6:
        table = table6(correlations, names)
    elif number in (7, 8, 10):
        table = ttest_table(number, correlations, angles, sensor_sets, reference(number))
    elif number in (9, 11):
        table = angle_table(number, angles, names)
    else:
        raise ValueError(f"Kong Table {number} is not one aceval reproduces (3-11)")
    return _tidy(table, number)


def _tidy(table: pd.DataFrame, number: int) -> pd.DataFrame:
    spec = TABLES[number]
    keys = [k for k in (spec["row"], spec.get("column")) if k]
    table = table.sort_values(keys, key=_sort_key, kind="stable").reset_index(drop=True)
    if "n" in table.columns:
        table["n"] = table["n"].fillna(0).astype(int)
    return rounded(table)


#: the columns that hold p-values: 3 significant digits in a CSV (:func:`rounded`: 4 decimals
#: would write 1e-5 as 0.0), '<0.001' below 0.001 in Markdown (:func:`_fmt_p`)
P_COLUMNS = ("p", "p_holm", "p_value")


def rounded(table: pd.DataFrame) -> pd.DataFrame:
    """p-values (:data:`P_COLUMNS`) to 3 significant digits, other floats to 4 decimals (stable,
    diff-friendly CSVs).
    """
    for column in table.columns:
        if column in P_COLUMNS:
            table[column] = [float(f"{v:.3g}") if np.isfinite(v) else np.nan for v in table[column]]
        elif pd.api.types.is_float_dtype(table[column]):
            table[column] = table[column].round(4)
    return table


# --- Markdown -----------------------------------------------------------------------------------


def _fmt(value, digits=3) -> str:
    if value is None or (isinstance(value, float) and not np.isfinite(value)):
        return ""
    text = f"{value:.{digits}f}"
    return text[1:] if text.startswith("-") and float(text) == 0 else text  # no "-0.000"


def _fmt_p(value) -> str:
    """A p-value as every Markdown table shows one: '<0.001' below 0.001 (3 decimals would print
    0.000), else 3 decimals; 'n/a' without one.
    """
    if value is None or not np.isfinite(value):
        return "n/a"
    return "<0.001" if value < 0.001 else f"{value:.3f}"


def _heading(title: str, dataset: str, simulated: bool, what: str) -> list[str]:
    return [
        f"# {title}",
        "",
        f"Dataset **{dataset}**"
        + (" (SIMULATED data, not the paper's recordings)" if simulated else "")
        + f". {what}",
        "",
    ]


def to_markdown(table: pd.DataFrame, output, dataset: str, simulated: bool) -> str:
    """Kong Table ``number`` as Markdown: the paper's layout, then beside the published values.
    ``output``: its entry in the registry (:mod:`aceval.report.outputs`: title, paper, unit).
    """
    number = int(output.name.removeprefix("table"))
    spec = TABLES[number]
    objective = output.paper.split("(")[-1].rstrip(")")
    lines = _heading(
        f"Kong et al. 2016, Table {number}: {output.title}",
        dataset,
        simulated,
        f"{objective}. n counts {output.unit}.",
    )
    if spec["kind"] == "ttest":
        lines += _ttest_markdown(table, spec)
    else:
        lines += _matrix_markdown(table, spec)
    return "\n".join(lines) + "\n"


def named_markdown(
    table: pd.DataFrame, title: str, unit: str, dataset: str, simulated: bool
) -> str:
    """A table beyond Kong's numbered ones as Markdown, labelled with its dataset (and SIMULATED)."""
    lines = _heading(title, dataset, simulated, f"n counts {unit}.")
    if table.empty:
        return "\n".join(lines + ["No data in this dataset for this table.", ""])
    shown = table.copy()
    for column in shown.columns:
        if column in P_COLUMNS:
            shown[column] = [_fmt_p(v) for v in shown[column]]
        elif pd.api.types.is_float_dtype(shown[column]):
            shown[column] = [_fmt(v) for v in shown[column]]
    return "\n".join(lines + [shown.to_markdown(index=False, disable_numparse=True), ""])


def _matrix_markdown(table: pd.DataFrame, spec: dict) -> list[str]:
    row, column = spec["row"], spec["column"]
    ours = table[table["n"] > 0]
    has_sd = "sd" in table.columns

    def cell(r):
        text = _fmt(r["mean"]) + (f" ± {_fmt(r['sd'])}" if has_sd and np.isfinite(r["sd"]) else "")
        return text + (" †" if r["flag"] else "")

    matrix = ours.assign(cell=ours.apply(cell, axis=1)).pivot(
        index=row, columns=column, values="cell"
    )
    matrix = matrix.reindex(
        columns=[c for c in _ordered(table[column]) if c in matrix.columns]
    ).fillna("")
    flag_text = (
        "correlation <= 0.95"
        if spec["kind"] == "correlation"
        else f"angle > {spec['flag_above']:g} deg"
    )
    lines = [
        "## This run, in the paper's layout",
        "",
        f"Mean{' ± SD' if has_sd else ''}; † marks {flag_text} (the paper's grey cells).",
        "",
        matrix.reset_index().to_markdown(index=False, disable_numparse=True),
        "",
        "## Beside the published values",
        "",
    ]
    long = pd.DataFrame(
        {
            row: table[row],
            column: table[column],
            "this run": [
                cell(r) if r["n"] > 0 else "not in this dataset" for _, r in table.iterrows()
            ],
            "n": table["n"],
            "paper": [
                _fmt(r["published_mean"])
                + (
                    f" ± {_fmt(r['published_sd'])}"
                    if has_sd and np.isfinite(r.get("published_sd", np.nan))
                    else ""
                )
                + (" †" if r["published_flag"] else "")
                if np.isfinite(r["published_mean"])
                else "not in the paper"
                for _, r in table.iterrows()
            ],
            "difference": [_fmt(v) for v in table["difference"]],
        }
    )
    return lines + [long.to_markdown(index=False, disable_numparse=True)]


#: what Tables 7, 8 and 10's markdown says of their three tests
_TTEST_NOTE = (
    "Three tests of the same contrast per row: the paper's paired t-test on "
    "pooled units (repetitions, subsets and T_ex of one subject are not independent, so its p is "
    "optimistic: it is shown because it is what the paper did); a paired t-test on the subjects "
    "(each subject's mean per set, its IMUs and sides averaged: a subject's left and right are "
    "not two units), on which aceval judges the paper's set-preference claims, with the "
    "smallest p an exact test on that many subjects reaches (2 / 2^n: 0.0625 for 5); a linear "
    "mixed model of the cells' paired differences (a cell: one IMU, Table 7: one side, of one "
    "subject; statsmodels MixedLM, REML) with a random intercept per subject, its estimate over "
    "its standard error referred to a t with subjects - 1 degrees of freedom (between-within: "
    "the set effect is a between-subject effect). A fit whose final optimiser did not converge "
    "or whose Hessian is not positive definite has no p and is not in the Holm family; a "
    "subjects' variance below a thousandth of the cells' is flagged 'boundary' (a singular "
    "fit). d_z = mean difference / SD of the differences. The cells are in table "
    "set_test_units. "
)


def _ttest_markdown(table: pd.DataFrame, spec: dict) -> list[str]:
    row = spec["row"]
    set_a, set_b = table["set_a"].iloc[0], table["set_b"].iloc[0]
    has_sd = "published_sd_a" in table.columns
    correlation = spec["kind_of_value"] == "correlation"

    def published(r, side):
        value = r[f"published_mean_{side}"]
        if not np.isfinite(value):
            return "not in the paper"
        return _fmt(value) + (f" ± {_fmt(r[f'published_sd_{side}'])}" if has_sd else "")

    def spread(r, side):
        sd = r[f"sd_{side}"]
        return _fmt(r[f"mean_{side}"]) + (f" ± {_fmt(sd)}" if np.isfinite(sd) else "")

    def units(r):
        if str(r["test"]).startswith("mixed"):
            fit = (
                f"; fit: {r['fit_flags']}"
                if isinstance(r["fit_flags"], str) and r["fit_flags"]
                else ""
            )
            return f"{int(r['n'])} cells, {int(r['n_groups'])} subjects{fit}" if r["n"] else "0"
        if r["test"] == "units" and r["n"]:  # what an exact test on these subjects can reach
            return f"{int(r['n'])} subjects (smallest exact p {_fmt_p(r['smallest_p'])})"
        return str(int(r["n"]))

    is_paper = table["test"] == "paper"
    long = pd.DataFrame(
        {
            row: np.where(is_paper, table[row], ""),
            "test": [SET_TESTS.get(t, t) for t in table["test"]],
            f"{set_a} (mean ± SD)": [spread(r, "a") if r["n"] else "" for _, r in table.iterrows()],
            f"{set_b} (mean ± SD)": [spread(r, "b") if r["n"] else "" for _, r in table.iterrows()],
            "difference [95% CI]": [
                f"{_fmt(r['mean_difference'])} [{_fmt(r['ci95_low'])}, {_fmt(r['ci95_high'])}]"
                if np.isfinite(r["mean_difference"])
                else ""
                for _, r in table.iterrows()
            ],
            "d_z": [_fmt(v, 2) for v in table["cohens_dz"]],
            "n": [units(r) for _, r in table.iterrows()],
            "p": [_fmt_p(v) for v in table["p"]],
            "p (Holm)": [_fmt_p(v) for v in table["p_holm"]],
            "better": table["better"],
            "paper frontal": [
                published(r, "a") if p else "" for p, (_, r) in zip(is_paper, table.iterrows())
            ],
            "paper lateral": [
                published(r, "b") if p else "" for p, (_, r) in zip(is_paper, table.iterrows())
            ],
            "paper p": np.where(is_paper, table["published_p"].fillna(""), ""),
            "paper better": np.where(is_paper, table["published_better"], ""),
        }
    )
    better = (
        "'better' is the set with the larger mean correlation (Table 7 marks no cell)"
        if correlation
        else "'better' is the set with the smaller mean angle (the paper's grey cells)"
    )
    notes = [note for note in table.get("note", pd.Series(dtype=str)).dropna().unique() if note]
    return [
        f"{set_a} vs {set_b} (compared with the paper's frontal/back and lateral sets); difference = "
        f"{set_a} - {set_b}. {_TTEST_NOTE}"
        f"p is raw; p (Holm) corrects each test's p across the rows of this table. {better}.",
        "",
        long.to_markdown(index=False, disable_numparse=True),
        *([""] + [f"Mixed model notes: {', '.join(notes)}."] if notes else []),
    ]


def _segment_rank(value) -> int:
    return SEGMENT_ORDER.index(value) if value in SEGMENT_ORDER else len(SEGMENT_ORDER)


def _sort_key(column: pd.Series) -> pd.Series:
    """Segments in the paper's order (head to foot), anything else alphabetically."""
    if column.name == "segment":
        return column.map(lambda v: (_segment_rank(v), str(v))).astype(str)
    return column


def _ordered(values: pd.Series) -> list:
    unique = list(dict.fromkeys(values))
    return sorted(unique, key=lambda v: (_segment_rank(v), str(v)))
