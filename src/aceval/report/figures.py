"""The figures, drawn with seaborn: Kong et al. 2016 Figures 6, 8, 9 and 10 "in spirit" (what
they plot, not their look), Ricci et al. 2014 Figures 4-5, and the figures beyond the papers.
Captions are in :mod:`aceval.report.outputs`.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402
import seaborn as sns  # noqa: E402

from aceval.calibrate.table import unflagged
from aceval.evaluation.objectives import SEGMENT_ORDER  # noqa: E402
from aceval.report.kong2016 import rename_tests  # noqa: E402


def _segments(values) -> list:
    present = list(dict.fromkeys(values))
    return [s for s in SEGMENT_ORDER if s in present] + sorted(
        s for s in present if s not in SEGMENT_ORDER
    )


def plot(
    number: int,
    correlations: pd.DataFrame | None,
    angles: pd.DataFrame | None,
    out: Path,
    title: str,
    paper_names: dict | None = None,
) -> None:
    """Draw Kong Figure ``number`` to ``out`` (PNG). ``title`` names the dataset (and says SIMULATED)."""
    names = paper_names or {}
    sns.set_theme(style="whitegrid", context="paper")
    if number in (6, 8):
        objective = "frontal_lateral" if number == 6 else "segment_pair"
        panel = "segment" if number == 6 else "pair"
        keys = ["subject", "sensor_set", "imu", panel, "t_ex", "t_ap"]
        chosen = (
            (correlations["objective"] == objective)
            & (correlations["signal"] == "acc")
            & unflagged(correlations)
        )  # the columns drawn, not copies of all (memory: benchmarks/README.md)
        data = correlations.loc[chosen, [*keys, "correlation"]]
        data = data.groupby(keys, as_index=False)["correlation"].mean()
        x, y, order_panels = (
            "t_ap",
            "correlation",
            _segments(data[panel]) if number == 6 else sorted(data[panel].unique()),
        )
        ylabel = "acceleration correlation"
    elif number in (9, 10):
        panel, x, y = "segment", "k", "error_angle_deg"
        chosen = angles["comparison"] == ("incremental" if number == 9 else "to_last")
        data = angles.loc[chosen, [panel, x, y, "test"]]
        order_panels = _segments(data[panel])
        ylabel = "error angle (deg)"
    else:
        raise ValueError(f"Kong Figure {number} is not one aceval draws (6, 8, 9, 10)")
    if data.empty:  # e.g. one sensor set: say so in the figure rather than stop the workflow
        figure = plt.figure(figsize=(6, 1.5))
        figure.text(
            0.5,
            0.5,
            f"Kong Fig. {number}, {title}: not testable on this dataset (no data)",
            ha="center",
            va="center",
            fontsize=9,
        )
        figure.savefig(out, dpi=120, metadata={"Software": None})
        plt.close(figure)
        return
    data["t_ex"] = rename_tests(data["t_ex" if "t_ex" in data else "test"], names)
    if x == "t_ap":
        data["t_ap"] = rename_tests(data["t_ap"], names)
    grid = sns.catplot(
        data=data,
        x=x,
        y=y,
        hue="t_ex",
        col=panel,
        col_order=order_panels,
        col_wrap=min(3, len(order_panels)),
        kind="point",
        errorbar="sd",
        dodge=0.3 if data["t_ex"].nunique() > 1 else False,  # seaborn divides by levels - 1
        hue_order=sorted(data["t_ex"].unique()),
        order=sorted(data[x].unique()),
        height=2.6,
        aspect=1.15,
        markersize=4,
        linewidth=1,
    )
    grid.set_axis_labels(
        {
            "t_ap": "T_ap (test the matrix is applied to)",
            "k": "k (repetitions before adding one)" if number == 9 else "k (repetitions used)",
        }[x],
        ylabel,
    )
    grid.set_titles("{col_name}")
    if grid.legend is not None:  # seaborn draws none for a single T_ex
        grid.legend.set_title("T_ex")
    grid.figure.suptitle(f"Kong Fig. {number} in spirit, {title}", y=1.02, fontsize=9)
    grid.figure.savefig(out, dpi=120, bbox_inches="tight", metadata={"Software": None})
    plt.close(grid.figure)


def _not_testable(out: Path, text: str) -> None:
    figure = plt.figure(figsize=(6, 1.5))
    figure.text(0.5, 0.5, text, ha="center", va="center", fontsize=9)
    figure.savefig(out, dpi=120, metadata={"Software": None})
    plt.close(figure)


def _save(figure, out: Path) -> None:
    figure.savefig(out, dpi=120, bbox_inches="tight", metadata={"Software": None})
    plt.close(figure)


def _lm_example(axes: pd.DataFrame, figure_title: str, out: Path) -> None:
    import numpy as np
    from scipy.spatial.transform import Rotation

    from aceval.data.rotations import axis_vector
    from aceval.methods.ricci import lm_fit, quaternion_matrix

    used = axes.dropna(subset=["residual_after_deg"])
    used = used[used["segment"] == "thorax"] if (used["segment"] == "thorax").any() else used
    if used.empty:
        return _not_testable(out, f"Ricci Fig. 4, {figure_title}: no LM fit in this dataset")
    first = used[["subject", "sensor_set", "imu"]].iloc[0]
    rows = used[(used[["subject", "sensor_set", "imu"]] == first).all(axis=1)]
    v_ref = np.stack([axis_vector(a) for a in rows["reference"]])
    v_est = rows[["axis_x", "axis_y", "axis_z"]].to_numpy(float)
    rho = rows["rho"].to_numpy(float)
    fit = lm_fit(v_ref, v_est, rho)
    q = fit.quaternion_history
    iterations = np.arange(len(q))
    euler = np.degrees(Rotation.from_quat(q, scalar_first=True).as_euler("ZYX"))[:, ::-1]
    residuals = np.stack([(v_ref - v_est @ quaternion_matrix(qk).T).ravel() for qk in q])
    figure, panels = plt.subplots(2, 2, figsize=(9, 6))
    for k, label in enumerate("wxyz"):
        panels[0, 0].plot(iterations, q[:, k], marker="o", ms=3, label=label)
    panels[0, 0].set(title="quaternion", xlabel="iteration")
    panels[0, 0].legend(fontsize=7)
    for k, label in enumerate(["roll (x)", "pitch (y)", "yaw (z)"]):
        panels[1, 0].plot(iterations, euler[:, k], marker="o", ms=3, label=label)
    panels[1, 0].set(title="Euler angles (deg)", xlabel="iteration")
    panels[1, 0].legend(fontsize=7)
    panels[0, 1].plot(iterations, residuals, marker=".", ms=3, lw=0.8)
    panels[0, 1].set(
        title=f"residual vector e (Eq. 5), {residuals.shape[1]} components", xlabel="iteration"
    )
    starts = Rotation.random(10, random_state=0).as_quat(scalar_first=True)
    for start in starts:
        run = lm_fit(v_ref, v_est, rho, q0_wxyz=start)
        panels[1, 1].semilogy(
            np.arange(len(run.cost_history)), run.cost_history, color="0.7", lw=0.8
        )
    panels[1, 1].semilogy(
        iterations, fit.cost_history, color="C3", marker="o", ms=3, label="from identity"
    )
    panels[1, 1].plot([], [], color="0.7", label="10 random starts")
    panels[1, 1].set(title="cost C (Eq. 6)", xlabel="iteration")
    panels[1, 1].legend(fontsize=7)
    figure.suptitle(
        f"Ricci Fig. 4 in spirit, {figure_title}: {first['subject']} {first['imu']} "
        f"({', '.join(rows['test'])}); {fit.n_iterations} iterations",
        fontsize=9,
    )
    figure.tight_layout()
    _save(figure, out)


def plot_named(name: str, data: dict, out: Path, title: str) -> None:
    """Draw a figure beyond Kong's numbered ones (:mod:`aceval.report.outputs`) from the tidy tables in
    ``data``.
    """
    from aceval.evaluation import methods_comparison
    from aceval.report import ricci2014

    sns.set_theme(style="whitegrid", context="paper")
    if name == "obj1_sensitivity":
        from aceval.report.kong2016 import correlation_sensitivity

        curve = correlation_sensitivity(data.get("correlations"))
        if curve.empty:
            return _not_testable(out, f"Obj 1 sensitivity, {title}: needs two sensor sets")
        figure, panel = plt.subplots(figsize=(5.5, 3.6))
        for mode, group in curve.groupby("mode", sort=False):
            panel.errorbar(group["heading_error_deg"], group["mean"], yerr=group["sd"], marker="o", ms=3,
                           capsize=2, label=mode)  # fmt: skip
        panel.set(xlabel="heading error imposed on the lateral calibration (deg)",
                  ylabel="acceleration correlation (Obj 1)")  # fmt: skip
        panel.legend(title="correlation", fontsize=7)
        figure.suptitle(f"What Kong's Obj 1 can detect, {title}", fontsize=9)
        figure.tight_layout()
        return _save(figure, out)
    if name == "ricci_figure4":
        return _lm_example(data["axes"], title, out)
    if name == "ricci_figure5":
        used = data["axes"].dropna(subset=["residual_after_deg"])
        if used.empty:
            return _not_testable(out, f"Ricci Fig. 5, {title}: no LM fit in this dataset")
        long = used.assign(segment=ricci2014.segment_label(used["segment"], used["side"])).melt(
            id_vars=["segment", "test"],
            value_vars=["residual_before_deg", "residual_after_deg"],
            var_name="when",
            value_name="residual angle (deg)",
        )
        long["when"] = long["when"].map(
            {"residual_before_deg": "before (identity)", "residual_after_deg": "after the fit"}
        )
        grid = sns.catplot(
            data=long,
            x="test",
            y="residual angle (deg)",
            hue="when",
            col="segment",
            col_wrap=3,
            kind="bar",
            errorbar="sd",
            height=2.6,
            aspect=1.1,
            sharex=False,
        )
        grid.figure.suptitle(f"Ricci Fig. 5 in spirit, {title}", y=1.02, fontsize=9)
        return _save(grid.figure, out)
    if name == "reliability":
        units = methods_comparison.kong_units(
            data["axes"], data["calibrations"], data.get("angles")
        )
        units = units.dropna(subset=["test_retest_deg"])
        if units.empty:
            return _not_testable(out, f"Reliability vs test-retest, {title}: no test-retest angles")
        figure, panels = plt.subplots(1, 2, figsize=(9, 3.6), sharey=True)
        for panel, (column, label) in zip(
            panels,
            [
                ("rho", "rho of the gyroscope axis (Ricci)"),
                ("planarity", "Kong planarity (0 = plane)"),
            ],
        ):
            sns.scatterplot(
                data=units,
                x=column,
                y="test_retest_deg",
                hue="test",
                hue_order=sorted(units["test"].unique()),
                s=14,
                ax=panel,
                legend=panel is panels[-1],
            )
            panel.set(xlabel=label, ylabel="test-retest angle (deg)", yscale="log")
        figure.suptitle(f"Reliability index vs Obj 4 test-retest angle, {title}", fontsize=9)
        figure.tight_layout()
        return _save(figure, out)
    if name == "methods":
        errors = methods_comparison.full_set_errors(data["calibrations"])
        if errors.empty:
            return _not_testable(out, f"Methods vs ground truth, {title}: no ground truth")
        order = [m for m in methods_comparison.METHOD_ORDER if m in set(errors["method"])]
        segments = _segments(errors["segment"])
        grid = sns.catplot(
            data=errors,
            x="test",
            y="error_deg",
            hue="method",
            hue_order=order,
            col="segment",
            col_order=segments,
            col_wrap=min(3, len(segments)),
            kind="point",
            estimator="median",
            errorbar=("pi", 50),
            dodge=0.4,
            order=sorted(errors["test"].unique()),
            height=2.6,
            aspect=1.15,
            markersize=4,
            linewidth=1,
            sharex=False,
        )
        grid.set_axis_labels("test", "error to the true mounting (deg)")
        grid.set_titles("{col_name}")
        grid.figure.suptitle(f"Methods against the ground truth, {title}", y=1.02, fontsize=9)
        return _save(grid.figure, out)
    raise ValueError(f"unknown figure {name!r} (aceval.report.outputs lists the figures)")
