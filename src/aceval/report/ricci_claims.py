"""Ricci et al. 2014's claims (reference/ricci2014/headline_findings.md) as rules on the reproduced
tables, each with 'holds', 'does not hold' or 'not testable on this dataset' and its numbers.
"""

from __future__ import annotations

from aceval.report.claims import (
    UNTESTABLE,
    Claim,
    _cells,
    _untestable,
    _verdict,
)


def ricci_claims(tables: dict) -> list[Claim]:
    """Ricci et al. 2014 (reference/ricci2014/headline_findings.md), from the ricci_* tables."""
    out = []
    table1 = _cells(tables.get("ricci_table1"))
    claim, rule = (
        "Static postures have rho about 0.97-0.99 (Table 1)",
        "every static cell's mean rho is in [0.96, 1]",
    )
    static = table1[table1["test"].isin(["TS/US/FS", "S"])] if len(table1) else table1
    if static.empty:
        out.append(_untestable("Ricci Table 1", claim, rule, "no static posture"))
    else:
        out.append(
            Claim(
                "Ricci Table 1",
                claim,
                rule,
                _verdict(bool(static["mean"].between(0.96, 1).all())),
                f"{static['mean'].min():.3f}-{static['mean'].max():.3f} over {len(static)} segments",
            )
        )
    claim = "Movement rho values of Table 1 are reproduced"
    rule = (
        "share of movement cells with a published value whose mean is within 2 published SD of it "
        "is above 50 %"
    )
    moving = (
        table1[~table1.index.isin(static.index)].dropna(subset=["published_mean"])
        if len(table1)
        else table1
    )
    if moving.empty:
        out.append(_untestable("Ricci Table 1", claim, rule, "no movement of Table 1"))
    else:
        close = moving["difference"].abs() <= 2 * moving["published_sd"]
        out.append(
            Claim(
                "Ricci Table 1",
                claim,
                rule,
                _verdict(float(close.mean()) > 0.5),
                f"{int(close.sum())} of {len(moving)} cells; this run {moving['mean'].min():.2f}-"
                f"{moving['mean'].max():.2f}, paper {moving['published_mean'].min():.2f}-"
                f"{moving['published_mean'].max():.2f}",
            )
        )
    ttest = _cells(tables.get("ricci_ttest"))
    claim = (
        "Supported movements (bar) have higher rho than unsupported ones, p < 0.05 for upper arms "
        "and forearms"
    )
    rule = (
        "the paper's reading, the same movement with and without the bar (shoulder flexion-extension "
        "FEB vs FE) at the upper-arm and forearm sensors: every row supported - unsupported > 0 with "
        "raw p < 0.05 (the paper quotes raw p); elbow FFEB vs FE, a different movement, is reported "
        "as a second reading"
    )
    if ttest.empty:
        out.append(_untestable("Ricci t-test", claim, rule, "needs FEB and FE (and FFEB)"))
    else:
        from aceval.report.ricci2014 import PRIMARY_READING

        primary = ttest[ttest["reading"] == PRIMARY_READING]
        second = ttest[ttest["reading"] != PRIMARY_READING]

        def listed(rows):
            return "; ".join(
                f"{r['segment']} {r['supported']}-{r['unsupported']} {r['mean_difference']:+.3f} "
                f"(p {r['p']:.2g})"
                for _, r in rows.iterrows()
            )

        ok = bool(len(primary)) and bool(
            ((primary["mean_difference"] > 0) & (primary["p"] < 0.05)).all()
        )
        out.append(
            Claim(
                "Ricci t-test",
                claim,
                rule,
                _verdict(ok) if len(primary) else UNTESTABLE,
                listed(primary) + (f"; second reading: {listed(second)}" if len(second) else ""),
            )
        )
    lm = _cells(tables.get("ricci_lm"))
    claim = "LM converges in thorax 6.34, upper arm 8.36, forearm 7.30 iterations (mean)"
    rule = "each frame's mean iterations within 2 of the published mean"
    lm_published = lm.dropna(subset=["published_mean"]) if len(lm) else lm
    if lm_published.empty:
        out.append(_untestable("Ricci LM", claim, rule, "no LM fit"))
    else:
        out.append(
            Claim(
                "Ricci LM",
                claim,
                rule,
                _verdict(bool((lm_published["difference"].abs() <= 2).all())),
                "; ".join(
                    f"{r['segment']} {r['mean']:.2f} ± {r['sd']:.2f} (paper {r['published_mean']:.2f})"
                    for _, r in lm_published.iterrows()
                ),
            )
        )
        claim = "LM converges from random initial quaternions too"
        rule = "at least 95 % of the random starts reach the closed-form optimum (within 0.1 deg)"
        share = float(lm["random_starts_optimum"].sum() / lm["random_starts"].sum())
        out.append(
            Claim(
                "Ricci LM",
                claim,
                rule,
                _verdict(share >= 0.95),
                f"{share:.1%} of {int(lm['random_starts'].sum())} starts; iterations mean "
                f"{lm['random_start_iterations_mean'].mean():.1f}, "
                f"max {int(lm['random_start_iterations_max'].max())} "
                "(paper: 12 in its example)",
            )
        )
    residuals = _cells(tables.get("ricci_residuals"))
    claim = "Residual angles shrink from the identity start to the fit"
    rule = "every segment x test: mean residual after < before"
    if residuals.empty:
        out.append(_untestable("Ricci residuals", claim, rule, "no LM fit"))
    else:
        per_test = residuals[residuals["test"] != "all"]
        out.append(
            Claim(
                "Ricci residuals",
                claim,
                rule,
                _verdict(bool((per_test["mean"] < per_test["before_mean"]).all())),
                f"before {per_test['before_mean'].min():.1f}-{per_test['before_mean'].max():.1f} deg, after "
                f"{per_test['mean'].min():.2f}-{per_test['mean'].max():.2f} deg",
            )
        )
        published = residuals.dropna(subset=["published_mean"])
        claim = "Residuals after the fit: thorax 5.39/2.56/2.86 deg (TR/TFE/supine), forearms 4.68/4.72 deg"
        rule = "each published residual is matched within 2 deg"
        out.append(
            Claim(
                "Ricci residuals",
                claim,
                rule,
                _verdict(bool((published["difference"].abs() <= 2).all())),
                "; ".join(
                    f"{r['segment']} {r['test']} {r['mean']:.2f} (paper {r['published_mean']:.2f})"
                    for _, r in published.iterrows()
                ),
            )
        )
    return out
