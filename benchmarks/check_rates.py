"""How often the static-posture check (aceval.checks.static_posture) flags clean data, and how
often it catches a static trial taken seated or leaning (not a speed benchmark: the rates in
config/README.md's table of checks come from here).

    python benchmarks/check_rates.py resources/kong_sim resources/box_sim resources/neura ...

Each argument is a dataset folder (the workflow writes the committed ones under resources/). For
every IMU with a static trial: the check on the clean data (a flag is a false alarm), then with its
static vertical turned by 10, 20, 45 and 90 deg about its declared right axis, one IMU at a time
(the check's own input, z0, turned: a flag is a catch).
"""

import sys

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

from aceval.dataset import load_dataset
from aceval.pipeline import imu_checks
from aceval.reduction import reduce_recordings
from aceval.rotations import AXIS_VECTORS

FLAG = "static_not_standing"
Z0 = ["z0_x", "z0_y", "z0_z"]


def rates(root: str) -> dict:
    dataset = load_dataset(root)
    summaries = pd.concat(
        [reduce_recordings(dataset, s).summaries for s in dataset.subjects.index],
        ignore_index=True,
    )
    clean = imu_checks(dataset, summaries)
    judged = [k for k, v in clean.items() if v.get("static_check_tests", 0) >= 2]
    row = {
        "dataset": root,
        "imus": len(clean),
        "judged": len(judged),
        "false_alarms": sum(v["flag"] == FLAG for v in clean.values()),
        "largest_clean_angle_deg": np.nanmax(
            [v.get("static_vertical_angle_deg", np.nan) for v in clean.values()] + [np.nan]
        ),
    }
    static = summaries["kind"] == "static"
    for degrees in (10, 20, 45, 90):
        caught = 0
        for key in judged:
            axis = np.asarray(AXIS_VECTORS[dataset.right_axis(key[1], key[2])], float)
            turn = Rotation.from_rotvec(np.radians(degrees) * axis).as_matrix()
            changed = summaries.copy()
            rows = static & (changed[["subject", "sensor_set", "imu"]] == key).all(axis=1)
            changed.loc[rows, Z0] = changed.loc[rows, Z0].to_numpy(float) @ turn.T
            caught += imu_checks(dataset, changed)[key]["flag"] == FLAG
        row[f"caught_{degrees}deg"] = f"{caught}/{len(judged)}"
    return row


if __name__ == "__main__":
    table = pd.DataFrame([rates(root) for root in sys.argv[1:]])
    print(table.to_string(index=False))
