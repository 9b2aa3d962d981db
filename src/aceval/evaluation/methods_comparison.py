"""Beyond both papers: every calibration method side by side against the ground truth, the
reliability indices and conditioning of Kong's tests, and real-data truths and references.

Input: the calibrations table of ``aceval calibrate`` on a dataset with ``ground_truth.tsv``
(``error_deg`` = angle of R R_true^T, Kong Eq. 11; ``error_vertical_share`` = the part of that
rotation about the body vertical). Each method is judged on its calibration from all repetitions
of a test (Ricci's functional design: from all its axes).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from aceval.calibrate.table import flag_sets, flag_text, full_set_rows, has_flag, unflagged
from aceval.data.contract import R_COLUMNS
from aceval.data.rotations import error_angle_deg, vector_angle_deg, vertical_share
from aceval.evaluation.conditioning import heading_status
from aceval.evaluation.objectives import SEGMENT_ORDER, test_retest_angles
from aceval.methods import registry

#: Kong et al. 2016 Sec. 4: the test recommended for each segment
KONG_RECOMMENDATION = {"head": "T3", "chest": "T3", "waist": "T3", "thigh": "T6", "shank": "T6"}


def full_set_errors(calibrations: pd.DataFrame) -> pd.DataFrame:
    """The calibrations from all repetitions, when not flagged, with a finite error to the truth
    (a flagged calibration from all repetitions is left out, not replaced by its subsets).
    """
    data = full_set_rows(calibrations)
    return data[unflagged(data) & np.isfinite(data["error_deg"])]


def _p95(values: pd.Series) -> float:
    return float(np.percentile(values, 95))


def _method_order(table: pd.DataFrame, keys: list[str]) -> pd.DataFrame:
    rank = table["method"].map(registry.rank)
    return (
        table.assign(method_rank=rank)
        .sort_values([*keys, "method_rank", "method"])
        .drop(columns="method_rank")
    )


def methods_table(
    calibrations: pd.DataFrame,
    test_retest_k: int | None = None,
    retest_units: pd.DataFrame | None = None,
) -> pd.DataFrame:
    """Error to the true mounting (deg) per method x test x segment x sensor set: mean, SD,
    median, 95th percentile, n, and the median share of the error about the vertical axis; with
    ``test_retest_k``, beside it the method's test-retest angle (:func:`retest_table`: median over
    subject x IMU units, and their number; ``retest_units`` as there).
    """
    data = full_set_errors(calibrations)
    keys = ["segment", "test", "sensor_set", "method"]
    table = (
        data.groupby(keys)
        .agg(
            mean=("error_deg", "mean"),
            sd=("error_deg", "std"),
            median=("error_deg", "median"),
            p95=("error_deg", _p95),
            n=("error_deg", "count"),
            vertical_share=("error_vertical_share", "median"),
        )
        .reset_index()
    )
    if "cone_deg" in data:  # the uncertainty cone (aceval.methods.uncertainty), where it has one
        cones = data.groupby(keys)["cone_deg"].median().rename("cone_median_deg")
        table = table.merge(cones.reset_index(), on=keys, how="left")
    retest = (
        retest_table(calibrations, test_retest_k, retest_units) if test_retest_k else pd.DataFrame()
    )
    if len(retest):  # Kong's design (Ricci's functional design has no subsets of repetitions)
        retest = retest[[*keys, "median", "n"]].rename(
            columns={"median": "retest_median_deg", "n": "retest_n"}
        )
        table = table.merge(retest, on=keys, how="left")
    table = _with_price(table, calibrations, keys)
    return _method_order(_with_not_applicable(table, calibrations, keys), keys[:3])


def _with_price(table: pd.DataFrame, calibrations: pd.DataFrame, keys) -> pd.DataFrame:
    """The price of the flags beside every cell's numbers: ``n_calibrations``, the calibrations
    from all repetitions the cell could hold (a peer that does not apply is not counted), of which
    ``n`` are unflagged and counted, and ``flags`` (those of the others, by how often); a cell
    whose every calibration is flagged keeps its row, with n = 0 and its flags.
    """
    full = full_set_rows(calibrations)
    full = full[flag_text(full["flag"]) != "not_applicable"]
    if full.empty:
        return table
    flagged = full[~unflagged(full)]
    counts = full.groupby(keys).size().rename("n_calibrations").reset_index()
    names = flagged.assign(name=flag_sets(flagged["flag"]).map(sorted)).explode("name")
    flags = (
        names.groupby([*keys, "name"])
        .size()
        .rename("count")
        .reset_index()
        .sort_values([*keys, "count", "name"], ascending=[True] * len(keys) + [False, True])
        .assign(text=lambda t: t["name"] + " x" + t["count"].astype(str))
        .groupby(keys)["text"]
        .agg("; ".join)
        .rename("flags")
        .reset_index()
    )
    priced = counts.merge(flags, on=keys, how="left")
    if table.empty:  # every calibration flagged: the cells' rows, n = 0
        table = priced.reindex(columns=[*table.columns, "n_calibrations", "flags"])
    else:
        table = table.merge(priced, on=keys, how="outer")
    table["n"] = table["n"].fillna(0).astype(int)
    table["flags"] = table["flags"].fillna("")
    return table


def _with_not_applicable(table: pd.DataFrame, calibrations: pd.DataFrame, keys) -> pd.DataFrame:
    """Rows (n = 0) for the methods that could not calibrate a segment in a test at all, with
    the reason in ``note`` (a peer that needs more than the dataset gives: OpenSense's
    orientations, qmt's second sensor on a joint).
    """
    if "note" not in calibrations or "flag" not in calibrations:
        return table
    flagged = calibrations[calibrations["flag"].astype(str) == "not_applicable"]
    if flagged.empty:
        return table
    reasons = flagged.groupby(keys)["note"].first().reset_index()
    done = set(map(tuple, table[keys].to_numpy())) if len(table) else set()
    extra = reasons[[tuple(r) not in done for r in reasons[keys].to_numpy()]]
    extra = extra.assign(n=0)
    return pd.concat([table.assign(note=""), extra], ignore_index=True)


#: a test-retest unit of :func:`retest_units`
RETEST_UNIT = ["subject", "sensor_set", "imu", "segment", "test", "method"]


def retest_units(calibrations: pd.DataFrame, k: int = 3) -> pd.DataFrame:
    """Every method's test-retest per unit (subject x set x IMU x test; Kong Obj 4, Eq. 15): the
    mean angle (deg, ``error_angle_deg``) between its calibrations from two distinct subsets of
    ``k`` repetitions, sorted by :data:`RETEST_UNIT`. Within a subject, so the workflow computes
    it per subject (``aceval calibrate --retest-out``).
    """
    # calibrations from subsets of repetitions ('R1+R3+R4'), not Ricci's design ('all')
    calibrations = calibrations[
        calibrations["repetitions"].astype(str).str.fullmatch(r"R\d+(\+R\d+)*")
    ]
    parts = [
        test_retest_angles(calibrations, k, method).assign(method=method)
        for method in calibrations["method"].dropna().unique()
    ]
    angles = pd.concat([p for p in parts if len(p)] or [pd.DataFrame()], ignore_index=True)
    if angles.empty:
        return pd.DataFrame(columns=[*RETEST_UNIT, "error_angle_deg"])
    return angles.groupby(RETEST_UNIT)["error_angle_deg"].mean().reset_index()


def every_retest_unit(
    calibrations: pd.DataFrame, k: int = 3, units: pd.DataFrame | None = None
) -> pd.DataFrame:
    """:func:`retest_units` of every method: ``units`` (those of the methods it holds, computed
    beforehand: the workflow's per-subject files) and the other methods' from ``calibrations``.
    """
    if units is None or not len(units):
        return retest_units(calibrations, k)
    rest = retest_units(calibrations[~calibrations["method"].isin(units["method"])], k)
    units = pd.concat([units, rest] if len(rest) else [units], ignore_index=True)
    return units.sort_values(RETEST_UNIT, kind="stable", ignore_index=True)


def retest_table(
    calibrations: pd.DataFrame, k: int = 3, units: pd.DataFrame | None = None
) -> pd.DataFrame:
    """Every method's test-retest (Kong Obj 4, Eq. 15, beyond Kong's own method): the angle (deg)
    between its calibrations from two distinct subsets of ``k`` repetitions, averaged per unit
    (subject x set x IMU, :func:`retest_units`), then mean, SD, median and 95th percentile over
    the units, per segment, test, sensor set and method; beside it the median uncertainty cone
    of the unflagged calibrations from all repetitions (methods with one). Repeatability, not
    accuracy: it needs no ground truth. ``units``: the units of the methods it holds, computed
    beforehand (the workflow's per-subject files); the other methods' from ``calibrations``.
    """
    columns = ["segment", "test", "sensor_set", "method", "mean", "sd", "median", "p95", "n"]
    if "note" in calibrations:
        columns.append("note")
    units = every_retest_unit(calibrations, k, units)
    if units.empty:
        return pd.DataFrame(columns=columns)
    keys = ["segment", "test", "sensor_set", "method"]
    table = (
        units.groupby(keys)["error_angle_deg"]
        .agg(mean="mean", sd="std", median="median", p95=_p95, n="count")
        .reset_index()
    )
    if "cone_deg" in calibrations:  # beside it, the cone of the full-set calibrations
        full = full_set_rows(calibrations)
        full = full[unflagged(full)]
        cones = full.groupby(keys)["cone_deg"].median().rename("cone_median_deg")
        table = table.merge(cones.reset_index(), on=keys, how="left")
    table = _with_price(table, calibrations, keys)
    return _method_order(_with_not_applicable(table, calibrations, keys), keys[:3])


def uncertainty_table(
    calibrations: pd.DataFrame, method_sheet: pd.DataFrame | None = None
) -> pd.DataFrame:
    """How often the truth falls inside a calibration's uncertainty cone (``cone_deg``,
    :mod:`aceval.methods.uncertainty`: what the recording shows of its uncertainty, scaled by
    constants fitted across simulator variants), per segment, test and method and (``segment``
    and ``test`` 'all') per method, over the unflagged calibrations from all repetitions with a
    cone and a truth (``n_undetermined``: those flagged ``heading_undetermined`` beside them, a
    cone beyond 90 deg: left out, never counted covered): ``n``,
    ``n_subjects``, the median cone, the repetitions' spread alone and the error (deg),
    ``coverage`` (error <= cone) with its 95 % interval (``coverage_low``, ``coverage_high``,
    ``interval``: resampled subjects, or binomial with few subjects,
    :func:`aceval.evaluation.stats.coverage_interval`), ``spread_coverage`` (error <= the spread
    alone: what the bootstrap covers without the model), and, on real data with a measured truth
    (``method_sheet``), ``coverage_with_truth`` (error minus the truth's own uncertainty <= cone).
    """
    columns = [
        "segment",
        "test",
        "method",
        "n",
        "n_undetermined",
        "n_subjects",
        "cone_median_deg",
        "spread95_median_deg",
        "error_median_deg",
        "coverage",
        "coverage_low",
        "coverage_high",
        "interval",
        "spread_coverage",
        "coverage_with_truth",
    ]
    if "cone_deg" not in calibrations:
        return pd.DataFrame(columns=columns)
    full = full_set_rows(calibrations)
    lost = full[has_flag(full["flag"], "heading_undetermined") & np.isfinite(full["error_deg"])]
    data = full_set_errors(calibrations)
    data = data[np.isfinite(data["cone_deg"].astype(float))]
    if data.empty:
        return pd.DataFrame(columns=columns)
    truth_sd = np.full(len(data), np.nan)
    if method_sheet is not None and "truth_uncertainty_deg" in method_sheet:
        key = ["subject", "sensor_set", "imu"]
        sheet = method_sheet.astype({"subject": str})[[*key, "truth_uncertainty_deg"]]
        truth_sd = data[key].astype({"subject": str}).merge(sheet, on=key, how="left")
        truth_sd = truth_sd["truth_uncertainty_deg"].to_numpy(float)
    data = data.assign(
        hit=data["error_deg"] <= data["cone_deg"],
        spread_hit=data["error_deg"] <= data["spread95_deg"],
        truth_hit=np.where(
            np.isfinite(truth_sd), data["error_deg"] - truth_sd <= data["cone_deg"], np.nan
        ),
    )
    groups = [
        *data.groupby(["segment", "test", "method"], sort=False),
        *((("all", "all", m), g) for m, g in data.groupby("method", sort=False)),
    ]
    lost = {
        **lost.groupby(["segment", "test", "method"]).size().to_dict(),
        **{("all", "all", m): n for m, n in lost.groupby("method").size().items()},
    }
    rows = [_coverage_row(key, group, lost.get(key, 0)) for key, group in groups]
    table = pd.DataFrame(rows, columns=columns)
    cells = _method_order(table[table["segment"] != "all"], ["segment", "test"])
    return pd.concat([cells, _method_order(table[table["segment"] == "all"], [])])[columns]


def _coverage_row(key: tuple, group: pd.DataFrame, n_undetermined: int) -> dict:
    """One row of :func:`uncertainty_table`: ``key`` (segment, test, method) and its group."""
    from aceval.evaluation.stats import coverage_interval

    low, high, how = coverage_interval(group["hit"], group["subject"])
    return {
        "segment": key[0],
        "test": key[1],
        "method": key[2],
        "n": len(group),
        "n_undetermined": int(n_undetermined),
        "n_subjects": group["subject"].nunique(),
        "cone_median_deg": group["cone_deg"].median(),
        "spread95_median_deg": group["spread95_deg"].median(),
        "error_median_deg": group["error_deg"].median(),
        "coverage": group["hit"].mean(),
        "coverage_low": low,
        "coverage_high": high,
        "interval": how,
        "spread_coverage": group["spread_hit"].mean(),
        "coverage_with_truth": group["truth_hit"].mean(),
    }


def with_truth(calibrations: pd.DataFrame, ground_truth: pd.DataFrame | None) -> pd.DataFrame:
    """``error_deg`` and ``error_vertical_share`` (Kong Eq. 11) filled in for rows that lack them
    (the peers' calibrations, made without the truth) from ``ground_truth`` (indexed by subject,
    set, IMU, with r11..r33).
    """
    if ground_truth is None or calibrations.empty:
        return calibrations
    missing = calibrations["error_deg"].isna() if "error_deg" in calibrations else None
    if missing is None:
        calibrations = calibrations.assign(error_deg=np.nan, error_vertical_share=np.nan)
        missing = pd.Series(True, index=calibrations.index)
    rows = calibrations[missing]
    keys = list(zip(rows["subject"], rows["sensor_set"], rows["imu"]))
    known = np.array([key in ground_truth.index for key in keys], dtype=bool)
    if not known.any():
        return calibrations
    chosen = rows[known]
    R = chosen[R_COLUMNS].to_numpy(float).reshape(-1, 3, 3)
    truth = (
        ground_truth.loc[[k for k, ok in zip(keys, known) if ok], R_COLUMNS]
        .to_numpy(float)
        .reshape(-1, 3, 3)
    )
    valid = np.isfinite(R).all(axis=(1, 2))
    out = calibrations.copy()
    index = chosen.index[valid]
    out.loc[index, "error_deg"] = error_angle_deg(R[valid], truth[valid])
    out.loc[index, "error_vertical_share"] = vertical_share(R[valid], truth[valid])
    return out


def method_medians(calibrations: pd.DataFrame) -> pd.DataFrame:
    """Per method: the median error over all calibrations and the median of the per-segment medians."""
    data = full_set_errors(calibrations)
    per_segment = data.groupby(["method", "segment"])["error_deg"].median()
    return pd.DataFrame(
        {
            "median_deg": data.groupby("method")["error_deg"].median(),
            "median_of_segment_medians_deg": per_segment.groupby("method").median(),
            "n": data.groupby("method")["error_deg"].count(),
        }
    ).reset_index()


def best_tests(calibrations: pd.DataFrame) -> pd.DataFrame:
    """Per segment and method, the test whose calibrations have the smallest median error (both
    sensor sets pooled), with Kong's recommended test and its median error beside it.
    """
    data = full_set_errors(calibrations)
    medians = data.groupby(["segment", "method", "test"])["error_deg"].median().reset_index()
    rows = []
    for (segment, method), group in medians.groupby(["segment", "method"], sort=True):
        best = group.loc[group["error_deg"].idxmin()]
        recommended = KONG_RECOMMENDATION.get(segment, "")
        at_recommended = group.loc[group["test"] == recommended, "error_deg"]
        rows.append(
            {
                "segment": segment,
                "method": method,
                "best_test": best["test"],
                "best_median_deg": best["error_deg"],
                "kong_recommends": recommended,
                "recommended_median_deg": float(at_recommended.iloc[0])
                if len(at_recommended)
                else np.nan,
            }
        )
    table = pd.DataFrame(rows)
    if table.empty:
        return table
    rank = table["segment"].map(
        lambda s: SEGMENT_ORDER.index(s) if s in SEGMENT_ORDER else len(SEGMENT_ORDER)
    )
    method_rank = table["method"].map(registry.rank)
    return (
        table.assign(segment_rank=rank, method_rank=method_rank)
        .sort_values(["segment_rank", "segment", "method_rank", "method"])
        .drop(columns=["segment_rank", "method_rank"])
    )


#: the marker-frame truth is used only where both its own checks pass (:func:`marker_frame_usable`):
#: its vertical check, the tilt between the accelerometer's vertical and the one its
#: angular-velocity fit alone gives (``marker_frame_vertical_check_deg``), and its long-axis check,
#: the heading correction the angular velocity of the segment's long axis asks of it
#: (``marker_frame_long_axis_check_deg``, :func:`aceval.data.truth.long_axis_heading_deg`; where
#: the segment has a long axis). The limits are a choice between what they read on the committed
#: data: vertical checks of NeuRA's pelvis and thighs 1.7-2.7 deg, gaitmap's
#: left foot 2.3 and NeuRA's left foot 4.98 (which passes) against NeuRA's shanks 8.7-18.5 and
#: right foot 13.0, where the marker frame twists about the segment; gaitmap's right foot (5.9)
#: fails it. Long-axis checks of the passing sensors 1.0-4.7 deg, but NeuRA's left thigh 14.4
#: (it sits 12.9 deg from the acceleration truth, which its own long-axis check puts
#: within 1.5), which the long-axis limit leaves out
MAX_MARKER_FRAME_VERTICAL_DEG = 5.0
MAX_MARKER_FRAME_LONG_AXIS_DEG = 5.0


def marker_frame_usable(vertical_check_deg, long_axis_check_deg) -> np.ndarray:
    """True where the marker-frame truth passes both its checks
    (:data:`MAX_MARKER_FRAME_VERTICAL_DEG`, :data:`MAX_MARKER_FRAME_LONG_AXIS_DEG`; a check that
    was not made, NaN, does not fail it).
    """
    vertical = np.asarray(vertical_check_deg, float)
    long_axis = np.asarray(long_axis_check_deg, float)
    return ~(vertical > MAX_MARKER_FRAME_VERTICAL_DEG) & ~(
        long_axis > MAX_MARKER_FRAME_LONG_AXIS_DEG
    )


def marker_frame_verdict(vertical_check_deg: float, long_axis_check_deg: float) -> str:
    """Why the marker-frame truth is not used for a sensor ('' where it is): the check(s) it
    fails, with their readings and limits.
    """
    failed = []
    if vertical_check_deg > MAX_MARKER_FRAME_VERTICAL_DEG:
        failed.append(
            f"its vertical check {vertical_check_deg:.1f} deg > {MAX_MARKER_FRAME_VERTICAL_DEG:g}"
        )
    if long_axis_check_deg > MAX_MARKER_FRAME_LONG_AXIS_DEG:
        failed.append(
            f"its long-axis check {long_axis_check_deg:.1f} deg > {MAX_MARKER_FRAME_LONG_AXIS_DEG:g}"
        )
    return "; ".join(failed)


def truth_errors(calibrations: pd.DataFrame, method_sheet: pd.DataFrame | None) -> pd.DataFrame:
    """Real recordings with a marker-based ground truth (``ground_truth_method.tsv``): per sensor,
    test and method (each from all repetitions), the error against the truth beside the truth's
    own uncertainty (``truth_uncertainty_deg``: its strides, points and time offsets,
    :func:`aceval.importers.vicon.truth_rows`), its flag and its independent long-axis check, the
    error against the second, marker-frame truth where that truth's own vertical and long-axis
    checks pass (:func:`marker_frame_usable`; else NaN, columns ``marker_frame_vertical_check_deg``
    and ``marker_frame_long_axis_check_deg`` say why), the two truths' difference, the marker frame's twist,
    where the sensor sits (lever arm from the segment's point), two sensors on one segment
    (their truths against their gyroscopes: heading and tilt) and the method's conditioning
    (Kong: the smallest/middle eigenvalue ratio and the planarity; ``heading`` says
    'undetermined' when the ratio is above Kong's 0.5).
    """
    columns = [
        "subject",
        "sensor_set",
        "imu",
        "segment",
        "side",
        "test",
        "method",
        "flag",
        "error_deg",
        "truth_uncertainty_deg",
        "truth_flag",
        "long_axis_check_deg",
        "error_marker_frame_deg",
        "marker_frame_vertical_check_deg",
        "marker_frame_long_axis_check_deg",
        "methods_differ_deg",
        "twist_mean_deg",
        "lever_arm_m",
        "pair_heading_deg",
        "pair_tilt_deg",
        "normal_ratio",
        "planarity",
        "heading",
    ]
    if method_sheet is None or calibrations.empty or "error_deg" not in calibrations:
        return pd.DataFrame(columns=columns)
    from aceval.data.contract import R_COLUMNS
    from aceval.data.rotations import error_angle_deg

    key = ["subject", "sensor_set", "imu"]
    full = full_set_rows(calibrations)
    sheet = method_sheet.astype({"subject": str})
    data = full.merge(sheet, on=key, how="inner", suffixes=("", "_truth"))
    marker = data[[f"marker_frame_{c}" for c in R_COLUMNS]].to_numpy(float).reshape(-1, 3, 3)
    R = data[R_COLUMNS].to_numpy(float).reshape(-1, 3, 3)
    if "marker_frame_vertical_check_deg" not in data:  # a truth sheet without the check
        data["marker_frame_vertical_check_deg"] = np.nan
    if "marker_frame_long_axis_check_deg" not in data:
        data["marker_frame_long_axis_check_deg"] = np.nan
    valid = np.isfinite(R).all(axis=(1, 2)) & marker_frame_usable(
        data["marker_frame_vertical_check_deg"], data["marker_frame_long_axis_check_deg"]
    )
    data["error_marker_frame_deg"] = np.nan
    data.loc[valid, "error_marker_frame_deg"] = error_angle_deg(R[valid], marker[valid])
    data["truth_flag"] = data["flag_truth"].astype(object).fillna("")
    data["flag"] = data["flag"].astype(object).fillna("")
    if "normal_ratio" not in data:
        data["normal_ratio"] = np.nan
    data["heading"] = heading_status(data["normal_ratio"])
    for column in columns:
        if column not in data:
            data[column] = np.nan
    data["method_rank"] = data["method"].map(registry.rank)
    return data.sort_values(["sensor_set", "imu", "test", "method_rank"])[columns].reset_index(
        drop=True
    )


def loose_reference_angles(
    calibrations: pd.DataFrame, reference: pd.DataFrame | None
) -> pd.DataFrame:
    """Orders of magnitude against a loose reference (``loose_reference.tsv``: a segment's right
    and up axes in sensor coordinates set by hand, not measured): per sensor, test and method (all
    repetitions, flagged ones included), the angle (deg) between the calibration's body y (row 2
    of R) and the reference's right axis, and between its body z (down) and the reference's down,
    beside the reference's own standing check (``standing_up_angle_deg``).
    """
    columns = [
        "subject",
        "sensor_set",
        "imu",
        "segment",
        "side",
        "test",
        "method",
        "flag",
        "right_axis_angle_deg",
        "vertical_angle_deg",
        "reference_standing_up_angle_deg",
    ]
    if reference is None or calibrations.empty:
        return pd.DataFrame(columns=columns)
    from aceval.data.contract import R_COLUMNS

    key = ["subject", "sensor_set", "imu"]
    full = full_set_rows(calibrations)
    data = full.merge(reference.astype({"subject": str}), on=key, how="inner")
    R = data[R_COLUMNS].to_numpy(float).reshape(-1, 3, 3)
    right = data[["right_x", "right_y", "right_z"]].to_numpy(float)
    up = data[["up_x", "up_y", "up_z"]].to_numpy(float)
    data["right_axis_angle_deg"] = vector_angle_deg(R[:, 1], right)
    data["vertical_angle_deg"] = vector_angle_deg(R[:, 2], -up)
    data["reference_standing_up_angle_deg"] = data["standing_up_angle_deg"]
    data["flag"] = data["flag"].astype(object).fillna("")
    data["method_rank"] = data["method"].map(registry.rank)
    return data.sort_values(["sensor_set", "imu", "test", "method_rank"])[columns].reset_index(
        drop=True
    )
