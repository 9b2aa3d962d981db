"""How often `aceval right-axis` proposes the right axis (not a speed benchmark: config/README.md
quotes its numbers).

    python benchmarks/check_right_axis.py resources/kong_sim resources/neura resources/hugadb ...

Each argument is a dataset folder whose declared right axes are known to be right (the simulated
mountings; the real datasets' sheets, checked against their truths or references). Per dataset and
verdict it counts the IMUs (sensor set x IMU) whose proposal agrees with the declaration (within
60 deg, the limit of ``right_axis_mismatch``), names only the axis, or disagrees.
"""

from __future__ import annotations

import sys

import pandas as pd

from aceval.data.dataset import load_dataset
from aceval.signals.right_axis import dataset_right_axes


def main(folders: list[str]) -> None:
    rows = []
    for folder in folders:
        for proposal in dataset_right_axes(load_dataset(folder)):
            agrees = proposal["agrees"]
            outcome = (
                "agrees"
                if agrees == "yes"
                else "axis only"
                if "axis" in agrees
                else ("no proposal" if not agrees else "disagrees")
            )
            rows.append({"dataset": folder.rstrip("/").split("/")[-1],
                         "verdict": proposal["verdict"], "outcome": outcome,
                         "segment": proposal["segment"]})  # fmt: skip
    table = pd.DataFrame(rows)
    pd.set_option("display.width", 200)
    print(table.groupby(["dataset", "verdict", "outcome"]).size().unstack(fill_value=0).to_string())
    print()
    print(table.groupby(["verdict", "outcome"]).size().unstack(fill_value=0).to_string())


if __name__ == "__main__":
    main(sys.argv[1:])
