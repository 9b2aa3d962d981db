"""Kong et al. 2016 Figures 6, 8, 9 and 10 "in spirit": what they plot, drawn with seaborn."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402
import seaborn as sns  # noqa: E402

from .tables import SEGMENT_ORDER, rename_tests  # noqa: E402

FIGURES = {
    6: "Acceleration correlation between the frontal/back and lateral sensor of each segment, by the "
       "test the matrices are applied to (T_ap) and the test they come from (T_ex); mean and SD over "
       "subjects and sides, each value averaged over the repetitions",
    8: "Acceleration correlation between body segments moved as one rigid body (same sensor set), by "
       "T_ap and T_ex; mean and SD over subjects, sets and sides",
    9: "'Incremental' error angle: the change of the calibration when one repetition is added to k "
       "repetitions (Kong Eq. 11-12), mean and SD by T_ex and segment",
    10: "'To last' error angle: calibration from k repetitions vs from all of them (Kong Eq. 13 is "
        "k = 1), mean and SD by T_ex and segment",
}


def _segments(values) -> list:
    present = list(dict.fromkeys(values))
    return [s for s in SEGMENT_ORDER if s in present] + sorted(s for s in present if s not in SEGMENT_ORDER)


def plot(number: int, correlations: pd.DataFrame | None, angles: pd.DataFrame | None, out: Path,
         title: str, paper_names: dict | None = None) -> None:
    """Draw Kong Figure ``number`` to ``out`` (PNG). ``title`` names the dataset (and says SIMULATED)."""
    names = paper_names or {}
    sns.set_theme(style="whitegrid", context="paper")
    if number in (6, 8):
        objective = "frontal_lateral" if number == 6 else "segment_pair"
        data = correlations[(correlations["objective"] == objective) & (correlations["signal"] == "acc")
                            & (correlations["flag"].fillna("") == "")].copy()
        panel = "segment" if number == 6 else "pair"
        keys = ["subject", "sensor_set", "imu", panel, "t_ex", "t_ap"]
        data = data.groupby(keys, as_index=False)["correlation"].mean()
        x, y, order_panels = "t_ap", "correlation", _segments(data[panel]) if number == 6 else sorted(data[panel].unique())
        ylabel = "acceleration correlation"
    elif number in (9, 10):
        data = angles[angles["comparison"] == ("incremental" if number == 9 else "to_last")].copy()
        panel, x, y = "segment", "k", "error_angle_deg"
        order_panels = _segments(data[panel])
        ylabel = "error angle (deg)"
    else:
        raise ValueError(f"Kong Figure {number} is not one aceval draws (6, 8, 9, 10)")
    if data.empty:  # e.g. one sensor set: say so in the figure rather than stop the workflow
        figure = plt.figure(figsize=(6, 1.5))
        figure.text(0.5, 0.5, f"Kong Fig. {number}, {title}: not testable on this dataset (no data)",
                    ha="center", va="center", fontsize=9)
        figure.savefig(out, dpi=120, metadata={"Software": None})
        plt.close(figure)
        return
    data["t_ex"] = rename_tests(data["t_ex" if "t_ex" in data else "test"], names)
    if x == "t_ap":
        data["t_ap"] = rename_tests(data["t_ap"], names)
    grid = sns.catplot(data=data, x=x, y=y, hue="t_ex", col=panel, col_order=order_panels,
                       col_wrap=min(3, len(order_panels)), kind="point", errorbar="sd", dodge=0.3,
                       hue_order=sorted(data["t_ex"].unique()), order=sorted(data[x].unique()),
                       height=2.6, aspect=1.15, markersize=4, linewidth=1)
    grid.set_axis_labels({"t_ap": "T_ap (test the matrix is applied to)",
                          "k": "k (repetitions before adding one)" if number == 9 else "k (repetitions used)"}[x], ylabel)
    grid.set_titles("{col_name}")
    grid.legend.set_title("T_ex")
    grid.figure.suptitle(f"Kong Fig. {number} in spirit, {title}", y=1.02, fontsize=9)
    grid.figure.savefig(out, dpi=120, bbox_inches="tight", metadata={"Software": None})
    plt.close(grid.figure)
