"""What the sheets declare against what they hold: a calibrates.tsv that calibrates nothing, and
fewer repetitions recorded than tests.tsv declares.
"""

from __future__ import annotations

import pandas as pd

from aceval.data.contract import ValidationReport


def check_calibrates_not_empty(calibrates: pd.DataFrame, report: ValidationReport) -> None:
    """An error when calibrates.tsv has no row: no motion test calibrates any IMU, so there is
    nothing to calibrate (``aceval calibrate`` would refuse after reading every file).
    """
    if calibrates.empty:
        report.error(
            "calibrates.tsv",
            "no rows: no motion test calibrates any IMU, nothing to calibrate; give one row "
            "(test, imu) per motion test that may calibrate an IMU (Kong Table 2)",
        )


def check_repetitions(
    recordings: pd.DataFrame, tests: pd.DataFrame, report: ValidationReport
) -> None:
    """A warning for each IMU of a subject and set recorded in a test fewer times than tests.tsv
    ``repetitions`` declares (a repetition missing from recordings.tsv, or a file left out of
    it): its calibrations then rest on fewer repetitions than the protocol's. ``recordings``:
    the unique rows (``rep`` a number); ``tests`` indexed by test.
    """
    declared = pd.to_numeric(tests["repetitions"], errors="coerce")
    known = recordings[recordings["test"].isin(tests.index) & recordings["rep"].notna()]
    key = ["subject", "sensor_set", "imu", "test"]
    recorded = known.groupby(key, sort=False)["rep"].agg(["nunique", list]).reset_index()
    recorded["declared"] = recorded["test"].map(declared)
    for row in recorded[recorded["nunique"] < recorded["declared"]].itertuples():
        reps = ", ".join(f"R{r}" for r in sorted(row.list))
        report.warning(
            "recordings.tsv",
            f"subject {row.subject}, set {row.sensor_set}, IMU {row.imu}: {row.nunique} "
            f"repetition(s) of {row.test} recorded ({reps}), tests.tsv declares {row.declared:g}: "
            "a repetition missing from recordings.tsv?",
        )
