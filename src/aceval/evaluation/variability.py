"""How variable the motion is, measured the same way on real and on simulated recordings (beyond
the papers): what the simulator's variability is set from, and checked against.

Per subject, test and segment (:func:`variability_table`), each the median over the subject's
units (IMU x sensor set) of:

* ``repetition_heading_deg``: how far one repetition's calibration turns from the calibration of
  all of them (Kong's "to last" with one repetition, Eq. 13): the repetition-to-repetition
  change of the motion's plane;
* ``test_retest_deg``: Kong's Obj 4, 3 of 5 repetitions against another 3 (Eq. 15);
* ``normal_ratio`` and ``planarity``: how well the accelerations of all repetitions lie in one
  plane (smallest/middle and smallest/largest eigenvalue, Kong Eq. 3);
* ``two_sensor_correlation``: two sensors on one segment, their calibrated accelerations'
  correlation (Kong Obj 1; the sensor sets' pairs).

:func:`real_vs_simulated` sets the committed datasets' tables side by side: per statistic, test
and segment, each real dataset's median and range over its subjects beside the simulation's
(``python -m aceval.evaluation.variability results`` writes
``results/variability/real_vs_simulated.csv`` and ``.md``; docs/simulation.md quotes it).
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

from aceval.calibrate.table import full_set_rows, rows_of_method, unflagged

STATISTICS = (
    "repetition_heading_deg",
    "test_retest_deg",
    "normal_ratio",
    "planarity",
    "two_sensor_correlation",
)
COLUMNS = ["statistic", "test", "segment", "subject", "value", "n_units"]
#: the committed datasets measured, real and simulated (config/config.yaml, config/real.yaml)
REAL = ("hugadb", "neura", "qmt_fullbody", "gaitmap_feet")
SIMULATED = ("kong_sim",)


def variability_table(
    calibrations: pd.DataFrame | None,
    angles: pd.DataFrame | None,
    correlations: pd.DataFrame | None,
) -> pd.DataFrame:
    """Per statistic (:data:`STATISTICS`), test, segment and subject: the median over the
    subject's units, and how many units (module docstring).
    """
    parts = []
    if angles is not None and len(angles):
        for name, comparison, k in (
            ("repetition_heading_deg", "to_last", 1),
            ("test_retest_deg", "test_retest", 3),
        ):
            chosen = angles[(angles["comparison"] == comparison) & (angles["k"] == k)]
            units = chosen.groupby(["test", "segment", "subject", "sensor_set", "imu"])[
                "error_angle_deg"
            ].mean()
            parts.append(_per_subject(units.rename("value").reset_index(), name))
    kong = rows_of_method(calibrations) if calibrations is not None and len(calibrations) else None
    if kong is not None and "normal_ratio" in kong:
        full = full_set_rows(kong)
        for name in ("normal_ratio", "planarity"):
            parts.append(_per_subject(full.rename(columns={name: "value"}), name))
    if correlations is not None and len(correlations):
        chosen = correlations[
            (correlations["objective"] == "frontal_lateral")
            & (correlations["signal"] == "acc")
            & unflagged(correlations)
        ]
        # each set calibrated from the test itself
        chosen = chosen[chosen["t_ex"] == chosen["t_ap"]]
        units = chosen.groupby(["t_ap", "segment", "subject", "imu"])["correlation"].mean()
        units = units.rename("value").reset_index().rename(columns={"t_ap": "test"})
        parts.append(_per_subject(units, "two_sensor_correlation"))
    parts = [p for p in parts if len(p)]
    return pd.concat(parts, ignore_index=True)[COLUMNS] if parts else pd.DataFrame(columns=COLUMNS)


def _per_subject(units: pd.DataFrame, name: str) -> pd.DataFrame:
    values = units.dropna(subset=["value"])
    out = values.groupby(["test", "segment", "subject"])["value"].agg(["median", "count"])
    out = out.reset_index().rename(columns={"median": "value", "count": "n_units"})
    return out.assign(statistic=name)


def real_vs_simulated(tables: dict[str, pd.DataFrame]) -> pd.DataFrame:
    """Per statistic, test and segment that a simulated dataset and at least one real one
    measure: per dataset, the median over its subjects and their range (``min``, ``max``), and
    ``n`` subjects; one row per dataset, ``kind`` real or simulated.
    """
    rows = []
    for name, table in tables.items():
        if table is None or table.empty:
            continue
        grouped = table.groupby(["statistic", "test", "segment"])["value"]
        summary = grouped.agg(median="median", min="min", max="max", n="count").reset_index()
        rows.append(summary.assign(dataset=name, kind="simulated" if name in SIMULATED else "real"))
    if not rows:
        return pd.DataFrame()
    table = pd.concat(rows, ignore_index=True)
    keys = ["statistic", "test", "segment"]
    both = table.groupby(keys)["kind"].transform(lambda k: {"real", "simulated"} <= set(k))
    order = {s: i for i, s in enumerate(STATISTICS)}
    table = table[both].assign(_s=table["statistic"].map(order))
    table = table.sort_values(["_s", "test", "segment", "kind", "dataset"]).drop(columns="_s")
    return table[["statistic", "test", "segment", "dataset", "kind", "median", "min", "max", "n"]]


def main(argv: list[str] | None = None) -> int:
    """``python -m aceval.evaluation.variability RESULTS``: the committed datasets' variability
    tables side by side, into RESULTS/variability/.
    """
    results = Path((argv if argv is not None else sys.argv[1:])[0])
    tables = {
        name: pd.read_csv(results / name / "tables" / "variability.csv")
        for name in (*REAL, *SIMULATED)
        if (results / name / "tables" / "variability.csv").is_file()
    }
    table = real_vs_simulated(tables)
    out = results / "variability"
    out.mkdir(parents=True, exist_ok=True)
    table.to_csv(out / "real_vs_simulated.csv", index=False, float_format="%.4f")
    (out / "real_vs_simulated.md").write_text(
        "# Variability of the motion: real recordings beside the simulation\n\n"
        "Per statistic, test and segment: each dataset's median over its subjects and their "
        "range (aceval.evaluation.variability; made by `python -m aceval.evaluation.variability "
        "results` from the committed `results/*/tables/variability.csv`).\n\n"
        + table.round(4).to_markdown(index=False)
        + "\n"
    )
    print(table.round(3).to_string(index=False))
    return 0


if __name__ == "__main__":
    sys.exit(main())
