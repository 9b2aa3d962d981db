"""Ricci's functional design: each IMU from the axes of every test functional_axes.tsv lists for
its segment, one calibration per axis method.
"""

from __future__ import annotations

import pandas as pd

from aceval.calibrate.plan import imu_checks
from aceval.calibrate.rows import method_rows
from aceval.calibrate.table import (
    AXES_COLUMNS,
    CALIBRATION_COLUMNS,
    KEY,
    SIGN_VERIFIED,
    axis_row,
    combine_flags,
    imu_identity,
)
from aceval.data.contract import R_COLUMNS
from aceval.data.dataset import Dataset
from aceval.methods import registry
from aceval.methods.functional import (
    MOMENT_COLUMNS,
    axis_of_sums,
    functional_fits,
)


def calibrate_functional(
    dataset: Dataset, summaries: pd.DataFrame, sensors: dict | None = None
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Ricci's protocol: for every (subject, set, IMU), the axes of the tests functional_axes.tsv
    lists for its segment (each pooled over all trials: Ricci computes rho from the 9-12
    repetitions of a movement), then one calibration per axis method, flagged by the sensor
    checks (``sensors``: :func:`aceval.calibrate.plan.imu_checks`, found here when None; its
    flags of the IMU and of the tests used) beside the methods' own flags.

    ``axes`` has one row per (subject, set, IMU, test) recorded, with rho (Ricci Table 1), the
    reference axis when the test is used for the IMU's segment, and the LM residual angles
    before (identity) and after the fit (Ricci Eq. 13, Fig. 5).
    """
    sensors = imu_checks(dataset, summaries) if sensors is None else sensors
    usable_rows = summaries[
        (summaries["flag"] == "") & summaries["kind"].isin(["static", "motion"])
    ]
    summed = usable_rows.groupby(KEY + ["test", "kind"], sort=True)[MOMENT_COLUMNS].sum()
    counts = usable_rows.groupby(KEY + ["test", "kind"], sort=True).size()
    references = {}
    calibrations, axes = [], []
    for (subject, sensor_set, imu), per_test in summed.groupby(level=[0, 1, 2], sort=True):
        identity = imu_identity(dataset, subject, sensor_set, imu)
        if (sensor_set, imu) not in references:
            sheet = dataset.reference_axes(sensor_set, imu)
            references[(sensor_set, imu)] = dict(zip(sheet["test"], sheet["axis"]))
        reference = references[(sensor_set, imu)]
        rows = []
        for (*_, test, kind), moments in zip(per_test.index, per_test.to_numpy(float)):
            estimate = axis_of_sums(moments, orient="mean" if kind == "static" else "phase")
            rows.append(
                axis_row(
                    identity,
                    test,
                    kind,
                    estimate,
                    reference.get(test, ""),
                    int(counts[(subject, sensor_set, imu, test, kind)]),
                )
            )
        table = pd.DataFrame(rows)
        used = table[table["reference"] != ""]
        if len(used) >= 2:
            fits = functional_fits(used, seed_key=(subject, sensor_set, imu))
            lm = fits[registry.paper_method("ricci2014")]
            if lm.get("R") is not None:
                table.loc[used.index, "residual_before_deg"] = lm["residual_before_deg"]
                table.loc[used.index, "residual_after_deg"] = lm["residual_after_deg"]
            base = {
                **identity,
                "test": "+".join(used["test"]),
                "repetitions": "all",
                "n_reps": int(used["n_recordings"].sum()),
                "n_samples": int(used["n_samples"].sum()),
            }
            verdict = sensors.get((subject, sensor_set, imu), {})
            per_test = [verdict.get("test_flags", {}).get(t, "") for t in used["test"]]
            sensor_flag = combine_flags(verdict.get("flag", ""), *per_test)
            calibrations += [
                row | {"flag": combine_flags(sensor_flag, row["flag"])}
                for row in method_rows(base, fits)
            ]
        axes.append(table)
    table = pd.DataFrame(calibrations, columns=None if calibrations else CALIBRATION_COLUMNS)
    # every axis is signed by its recordings' first phase, not by the declared right axis
    table[SIGN_VERIFIED] = table[R_COLUMNS].notna().all(axis=1).astype(bool)
    return table, (
        pd.concat(axes, ignore_index=True)[AXES_COLUMNS]
        if axes
        else pd.DataFrame(columns=AXES_COLUMNS)
    )
