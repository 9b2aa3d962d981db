"""Recovery accuracy of the Kong calibration (all 5 repetitions) against a simulated dataset's
ground truth. Run: ``python benchmarks/simulation_accuracy.py DATASET_DIR``."""

import sys

import pandas as pd

from aceval.calibrate.pipeline import calibrate
from aceval.data.dataset import load_dataset
from aceval.evaluation.methods_comparison import with_truth
from aceval.signals.reduction import summarise_recordings


def main(root: str) -> None:
    dataset = load_dataset(root)
    calibrations, _ = calibrate(dataset, summarise_recordings(dataset), subsets="full")
    calibrations = with_truth(calibrations, dataset.ground_truth)  # the errors to the truth
    calibrations = calibrations.query("method == 'kong'")
    pd.set_option("display.width", 200)
    by_segment = calibrations.groupby(["segment", "sensor_set"])["error_deg"].agg(
        ["median", "mean", "max", "count"]
    )
    print("error to ground truth (deg) by segment and sensor set")
    print(by_segment.round(2).unstack())
    print("\nmedian error (deg) by segment and test")
    print(
        calibrations.pivot_table(
            index="segment", columns="test", values="error_deg", aggfunc="median"
        ).round(2)
    )
    print(
        f"\nall {len(calibrations)} calibrations: median {calibrations['error_deg'].median():.2f} deg"
    )


if __name__ == "__main__":
    main(sys.argv[1])
