"""Calibrate a lab's dataset folder and plot how each IMU's calibration depends on the test.

    python examples/calibrate_lab_folder.py [DATASET] [OUT]

DATASET is a folder in aceval's contract (config/README.md); without one, a small SIMULATED
dataset (Kong's protocol, one subject) is written into OUT first. OUT (default:
./example_output) receives calibrations.csv (one row per IMU, test and method, all repetitions)
and calibrations.png: for every IMU, the angle between each test's calibration and the first
test's (Kong Obj 5), and the error to the ground truth where the dataset has one.
"""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from aceval.calibrate.pipeline import calibrate  # noqa: E402
from aceval.calibrate.table import unflagged
from aceval.data.dataset import load_dataset  # noqa: E402
from aceval.evaluation.methods_comparison import with_truth  # noqa: E402
from aceval.evaluation.objectives import cross_test_angles
from aceval.signals.reduction import summarise_recordings  # noqa: E402
from aceval.simulate import SimOptions, simulate_kong  # noqa: E402

out = Path(sys.argv[2] if len(sys.argv) > 2 else "example_output")
out.mkdir(parents=True, exist_ok=True)
if len(sys.argv) > 1 and sys.argv[1]:
    root = Path(sys.argv[1])
else:
    root = out / "simulated_lab"
    if not root.exists():
        simulate_kong(root, seed=0, n_subjects=1, options=SimOptions(repetitions=2))

dataset = load_dataset(root, check_files=True)  # raises DatasetError with the validator's report
summaries = summarise_recordings(
    dataset
)  # one row per recording: what was kept, flagged or left out
calibrations, _ = calibrate(dataset, summaries, subsets="full")
calibrations = with_truth(calibrations, dataset.ground_truth)  # the errors to the truth
calibrations.to_csv(out / "calibrations.csv", index=False)
for message in summaries.loc[summaries["flag"] != "", "message"]:
    print("left out:", message)

kong = calibrations[calibrations["method"] == "kong"]
cross = cross_test_angles(kong)
figure, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
for imu, group in cross.groupby("imu"):
    left.plot(group["test"], group["error_angle_deg"], "o", label=imu)
left.set(title="Kong: angle between two tests' calibrations", ylabel="deg")
left.legend(fontsize=7)
if np.isfinite(calibrations["error_deg"]).any():
    for method, group in calibrations.groupby("method"):
        right.plot(group["imu"] + " " + group["test"], group["error_deg"], "o", label=method)
    right.set(title="error to the ground truth", ylabel="deg")
    right.tick_params(axis="x", rotation=90, labelsize=6)
    right.legend(fontsize=7)
figure.tight_layout()
figure.savefig(out / "calibrations.png", dpi=100)
valid = calibrations[unflagged(calibrations)]
medians = valid.groupby("method")["error_deg"].median().round(2).to_dict()
n_flagged = len(calibrations) - len(valid)
print(f"{len(calibrations)} calibrations ({n_flagged} flagged) -> {out / 'calibrations.csv'}")
print(f"median error to the ground truth by method (deg): {medians}")
