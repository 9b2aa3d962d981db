"""The figures, drawn with Matplotlib in seaborn's look (its "whitegrid" style in the "paper"
context, :data:`STYLE`; seaborn itself is not imported: its categorical plots cost a pandas
aggregation per point): Kong et al. 2016 Figures 6, 8, 9 and 10 "in spirit" (what they plot, not
their look), Ricci et al. 2014 Figures 4-5, and the figures beyond the papers. Captions are in
:mod:`aceval.report.outputs`.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from aceval.calibrate.table import unflagged
from aceval.evaluation.objectives import SEGMENT_ORDER  # noqa: E402
from aceval.report.kong2016 import rename_tests  # noqa: E402

#: seaborn 0.13's ``set_theme(style="whitegrid", context="paper")``, the Matplotlib settings it
#: changes (the look the figures had when seaborn drew them)
STYLE = {
    "axes.axisbelow": True,
    "axes.edgecolor": ".8",
    "axes.grid": True,
    "axes.labelcolor": ".15",
    "axes.labelsize": 9.6,
    "axes.linewidth": 1.0,
    "axes.titlesize": 9.6,
    "font.sans-serif": [
        "Arial",
        "DejaVu Sans",
        "Liberation Sans",
        "Bitstream Vera Sans",
        "sans-serif",
    ],
    "font.size": 9.6,
    "grid.color": ".8",
    "legend.fontsize": 8.8,
    "legend.title_fontsize": 9.6,
    "lines.linewidth": 1.2,
    "lines.markersize": 4.8,
    "lines.solid_capstyle": "round",
    "patch.edgecolor": "w",
    "patch.force_edgecolor": True,
    "patch.linewidth": 0.8,
    "text.color": ".15",
    "xtick.bottom": False,
    "xtick.color": ".15",
    "xtick.labelsize": 8.8,
    "xtick.major.size": 4.8,
    "xtick.major.width": 1.0,
    "xtick.minor.size": 3.2,
    "xtick.minor.width": 0.8,
    "ytick.color": ".15",
    "ytick.labelsize": 8.8,
    "ytick.left": False,
    "ytick.major.size": 4.8,
    "ytick.major.width": 1.0,
    "ytick.minor.size": 3.2,
    "ytick.minor.width": 0.8,
}
#: seaborn's "deep" palette, cycled for more levels
PALETTE = ["#4c72b0", "#dd8452", "#55a868", "#c44e52", "#8172b3", "#937860", "#da8bc3", "#8c8c8c"]
PALETTE += ["#ccb974", "#64b5cd"]


def _set_style() -> None:
    matplotlib.rcParams.update(STYLE)
    matplotlib.rcParams["axes.prop_cycle"] = matplotlib.cycler(color=PALETTE)


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
    _set_style()
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
    estimator="mean",
    errorbar="sd",
) -> plt.Figure:
    """One panel per ``col`` value (three to a row), each the ``estimator`` of ``y`` per ``x``
    category (``order``; None: the panel's own, in order of appearance) and ``hue`` level, with
    its ``errorbar`` ('sd': the mean's SD; ('pi', 50): the middle half), as points joined by lines
    (``kind`` 'point', the levels dodged) or bars side by side ('bar'), the y axis (and with
    ``sharex`` the x axis) shared, one legend beside them: what seaborn's ``catplot`` draws.
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
    colors = {level: PALETTE[k % len(PALETTE)] for k, level in enumerate(hue_order)}
    summary = _estimates(data, [col, hue, x], y, estimator, errorbar)
    for k, (panel, name) in enumerate(zip(axes.flat, col_order)):
        rows = summary.loc[summary[col] == name]
        categories = order or list(dict.fromkeys(data.loc[data[col] == name, x]))
        draw = _points if kind == "point" else _bars
        draw(panel, rows, x, hue, categories, colors)
        panel.xaxis.grid(False)
        panel.set_xticks(range(len(categories)), [str(c) for c in categories])
        panel.set_xlim(-0.5, len(categories) - 0.5)
        panel.set_title(str(name))
        panel.set_xlabel(xlabel if k // ncols == nrows - 1 or k + ncols >= len(col_order) else "")
        _labels_with_ticks(panel)
        panel.set_ylabel(ylabel if k % ncols == 0 else "")
    for panel in axes.flat[len(col_order) :]:
        panel.set_visible(False)
    for panel in axes.flat:
        panel.spines[["top", "right"]].set_visible(False)
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


def _labels_with_ticks(panel) -> None:
    """As seaborn: an axis's label is shown only where its tick labels are (a shared axis shows
    them on the outer panels only).
    """
    for axis in (panel.xaxis, panel.yaxis):
        axis.label.set_visible(any(label.get_visible() for label in axis.get_ticklabels()))


def _estimates(data, by: list, y: str, estimator: str, errorbar) -> pd.DataFrame:
    """Per group of ``by``: ``y`` (the ``estimator``, 'mean' or 'median'), ``low`` and ``high``
    (the mean -+ the SD for ``errorbar`` 'sd'; for ('pi', w) the middle w percent), in one
    grouping of the table.
    """
    grouped = data.groupby(by, sort=False)[y]
    out = grouped.agg(estimator).rename("estimate").to_frame()
    if errorbar == "sd":
        spread = grouped.std()
        out["low"], out["high"] = out["estimate"] - spread, out["estimate"] + spread
    else:
        share = errorbar[1]
        out["low"] = grouped.quantile((50 - share / 2) / 100)
        out["high"] = grouped.quantile((50 + share / 2) / 100)
    return out.reset_index()


def _points(panel, rows, x, hue, categories, colors) -> None:
    """Each hue level's estimates as points joined by a line, with their error bars, the levels
    dodged across 0.3 of a category (seaborn's ``pointplot``).
    """
    position = {c: k for k, c in enumerate(categories)}
    dodge = 0.3 if len(colors) > 1 else 0.0
    for k, (level, color) in enumerate(colors.items()):
        mine = rows.loc[rows[hue] == level].set_index(x).reindex(categories)
        offset = -dodge / 2 + (dodge / (len(colors) - 1) * k if len(colors) > 1 else 0.0)
        at = np.array([position[c] for c in categories], float) + offset
        estimate = mine["estimate"].to_numpy(float)
        panel.plot(at, estimate, marker="o", color=color, lw=1, markersize=4, markeredgewidth=0.75)
        bars = np.full((len(at), 3), np.nan)
        low, high = mine["low"].to_numpy(float), mine["high"].to_numpy(float)
        bars[:, 0], bars[:, 1] = low, high
        panel.plot(np.repeat(at, 3), bars.ravel(), color=color, linewidth=1)


def _bars(panel, rows, x, hue, categories, colors) -> None:
    """Each hue level's estimates as bars side by side within 0.8 of a category, in its colour
    desaturated to 0.75 (seaborn's default), with their error bars (seaborn's ``barplot``).
    """
    import colorsys

    position = {c: k for k, c in enumerate(categories)}
    width = 0.8 / len(colors)
    offsets = np.linspace(0, 0.8 - width, len(colors))
    offsets -= offsets.mean()
    for offset, (level, color) in zip(offsets, colors.items()):
        mine = rows.loc[rows[hue] == level]
        mine = mine.loc[mine[x].isin(position)]
        at = mine[x].map(position).to_numpy(float) + offset
        hue_, light, saturation = colorsys.rgb_to_hls(*matplotlib.colors.to_rgb(color))
        face = colorsys.hls_to_rgb(hue_, light, 0.75 * saturation)
        panel.bar(at - width / 2, mine["estimate"], width=width, align="edge", color=face)
        bars = np.full((len(at), 3), np.nan)
        bars[:, 0], bars[:, 1] = mine["low"].to_numpy(float), mine["high"].to_numpy(float)
        panel.plot(np.repeat(at, 3), bars.ravel(), color=".26", linewidth=1.8)


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
    _set_style()
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
    levels = sorted(units["test"].unique())
    colors = {level: PALETTE[k % len(PALETTE)] for k, level in enumerate(levels)}
    for panel, (column, label) in zip(
        panels,
        [("rho", "rho of the gyroscope axis (Ricci)"), ("planarity", "Kong planarity (0 = plane)")],
    ):
        panel.scatter(
            units[column],
            units["test_retest_deg"],
            s=14,
            c=units["test"].map(colors).tolist(),
            edgecolor="w",
            linewidth=0.08 * np.sqrt(14),
        )  # one call, in the table's order (which point lies on top), as seaborn's scatterplot
        panel.set(xlabel=label, ylabel="test-retest angle (deg)", yscale="log")
        _labels_with_ticks(panel)
    handles = [
        plt.Line2D([], [], marker="o", linestyle="", color=c, markersize=np.sqrt(14), mec="w")
        for c in colors.values()
    ]
    panels[-1].legend(handles, levels, title="test")
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
