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
    figure = _facets(
        data,
        x=x,
        y=y,
        hue="t_ex",
        col=panel,
        col_order=order_panels,
        kind="point",
        hue_order=sorted(data["t_ex"].unique()),
        order=sorted(data[x].unique()),
        xlabel={
            "t_ap": "T_ap (test the matrix is applied to)",
            "k": "k (repetitions before adding one)" if number == 9 else "k (repetitions used)",
        }[x],
        ylabel=ylabel,
        legend_title="T_ex",
        errorbar="sd",
    )
    figure.suptitle(f"Kong Fig. {number} in spirit, {title}", y=1.02, fontsize=9)
    _save(figure, out)


def _facets(
    data,
    *,
    x,
    y,
    hue,
    col,
    col_order,
    hue_order,
    order,
    kind,
    xlabel,
    ylabel,
    legend_title,
    height=2.6,
    aspect=1.15,
    sharex=True,
    **estimate,
) -> plt.Figure:
    """One panel per ``col`` value (three to a row), each seaborn's ``pointplot`` or ``barplot``
    (``kind``) of ``y`` over ``x`` by ``hue`` with the ``estimate`` options (estimator, errorbar),
    the y axis (and with ``sharex`` the x axis) shared, one legend beside them: what
    ``sns.catplot`` draws, in one layout pass (catplot's grid lays the figure out three times:
    45 % of a figure's time).
    """
    ncols = min(3, len(col_order))
    nrows = -(-len(col_order) // ncols)
    figure, axes = plt.subplots(
        nrows,
        ncols,
        figsize=(height * aspect * ncols, height * nrows),
        sharex=sharex,
        sharey=True,
        squeeze=False,
    )
    colors = dict(zip(hue_order, sns.color_palette(n_colors=len(hue_order))))
    draw = sns.pointplot if kind == "point" else sns.barplot
    style = (
        {"markersize": 4, "linewidth": 1, "dodge": 0.3 if len(hue_order) > 1 else False}
        if kind == "point"
        else {}
    )  # seaborn's point dodge is divided by the levels - 1
    for k, (panel, name) in enumerate(zip(axes.flat, col_order)):
        draw(
            data=data[data[col] == name],
            x=x,
            y=y,
            hue=hue,
            hue_order=hue_order,
            order=order,
            palette=colors,
            legend=False,
            ax=panel,
            **style,
            **estimate,
        )
        panel.set_title(str(name))
        panel.set_xlabel(xlabel if k // ncols == nrows - 1 or k + ncols >= len(col_order) else "")
        panel.set_ylabel(ylabel if k % ncols == 0 else "")
    for panel in axes.flat[len(col_order) :]:
        panel.set_visible(False)
    sns.despine(figure)
    if len(hue_order) > 1:  # as catplot: no legend for a single level
        marker = {"marker": "o", "markersize": 4} if kind == "point" else {"linewidth": 6}
        handles = [plt.Line2D([], [], color=c, **marker) for c in colors.values()]
        figure.legend(
            handles,
            list(colors),
            title=legend_title,
            loc="center left",
            bbox_to_anchor=(1.0, 0.5),
            frameon=False,
        )
    figure.tight_layout()
    return figure


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
    """Draw a figure beyond Kong's numbered ones (:mod:`aceval.report.outputs`) from the tidy tables
    in ``data``.
    """
    sns.set_theme(style="whitegrid", context="paper")
    if name == "ricci_figure4":
        return _lm_example(data["axes"], title, out)
    drawers = {
        "obj1_sensitivity": _sensitivity,
        "ricci_figure5": _ricci_residuals,
        "reliability": _reliability,
        "methods": _methods,
    }
    if name not in drawers:
        raise ValueError(f"unknown figure {name!r} (aceval.report.outputs lists the figures)")
    return drawers[name](data, out, title)


def _sensitivity(data: dict, out: Path, title: str) -> None:
    """What Kong's Obj 1 can detect: the correlation against an imposed heading error."""
    from aceval.report.kong2016 import correlation_sensitivity

    curve = correlation_sensitivity(data.get("correlations"))
    if curve.empty:
        return _not_testable(out, f"Obj 1 sensitivity, {title}: needs two sensor sets")
    figure, panel = plt.subplots(figsize=(5.5, 3.6))
    for mode, group in curve.groupby("mode", sort=False):
        panel.errorbar(
            group["heading_error_deg"],
            group["mean"],
            yerr=group["sd"],
            marker="o",
            ms=3,
            capsize=2,
            label=mode,
        )
    panel.set(
        xlabel="heading error imposed on the lateral calibration (deg)",
        ylabel="acceleration correlation (Obj 1)",
    )
    panel.legend(title="correlation", fontsize=7)
    figure.suptitle(f"What Kong's Obj 1 can detect, {title}", fontsize=9)
    figure.tight_layout()
    return _save(figure, out)


def _ricci_residuals(data: dict, out: Path, title: str) -> None:
    """Ricci Fig. 5 in spirit: residual angles before (identity) and after the LM."""
    from aceval.report import ricci2014

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
    figure = _facets(
        long,
        x="test",
        y="residual angle (deg)",
        hue="when",
        col="segment",
        col_order=list(dict.fromkeys(long["segment"])),
        kind="bar",
        hue_order=list(dict.fromkeys(long["when"])),
        order=None,
        xlabel="test",
        ylabel="residual angle (deg)",
        legend_title="when",
        aspect=1.1,
        errorbar="sd",
        sharex=False,
    )
    figure.suptitle(f"Ricci Fig. 5 in spirit, {title}", y=1.02, fontsize=9)
    return _save(figure, out)


def _reliability(data: dict, out: Path, title: str) -> None:
    """The reliability indices (rho, planarity) against the Obj 4 test-retest angle."""
    from aceval.evaluation import conditioning

    units = conditioning.kong_units(data["axes"], data["calibrations"], data.get("angles"))
    units = units.dropna(subset=["test_retest_deg"])
    if units.empty:
        return _not_testable(out, f"Reliability vs test-retest, {title}: no test-retest angles")
    figure, panels = plt.subplots(1, 2, figsize=(9, 3.6), sharey=True)
    for panel, (column, label) in zip(
        panels,
        [("rho", "rho of the gyroscope axis (Ricci)"), ("planarity", "Kong planarity (0 = plane)")],
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


def _methods(data: dict, out: Path, title: str) -> None:
    """Every method's error to the ground truth, per segment and test (median and quartiles)."""
    from aceval.evaluation import methods_comparison
    from aceval.methods import registry

    errors = methods_comparison.full_set_errors(data["calibrations"])
    if errors.empty:
        return _not_testable(out, f"Methods vs ground truth, {title}: no ground truth")
    order = registry.ordered(errors["method"])
    figure = _facets(
        errors,
        x="test",
        y="error_deg",
        hue="method",
        col="segment",
        col_order=_segments(errors["segment"]),
        kind="point",
        hue_order=order,
        order=sorted(errors["test"].unique()),
        xlabel="test",
        ylabel="error to the true mounting (deg)",
        legend_title="method",
        estimator="median",
        errorbar=("pi", 50),
        sharex=False,
    )
    figure.suptitle(f"Methods against the ground truth, {title}", y=1.02, fontsize=9)
    return _save(figure, out)
