"""What Kong's rules read (:class:`Evidence`) and the one comparison most of them make: every
cell's subject mean against the paper's bound (:func:`cells_against`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import pandas as pd

from aceval.calibrate.table import unflagged
from aceval.report.claims import (
    UNTESTABLE,
    beyond,
    cell_estimates,
    every,
    interval,
    subject_cells,
    tally,
)

#: the segment of Kong's rigid box (Tables 4-5, ``aceval simulate box``): not a body segment,
#: so not in the claims about segments
RIGID_BOX = "box"


@dataclass
class Evidence:
    """What Kong's rules read: the reproduced tables (by number or name), the Obj 1-2
    correlations, the Obj 3-5 angles and the calibrations (their errors to a truth, if any).
    """

    tables: dict
    correlations: pd.DataFrame | None
    angles: pd.DataFrame | None
    calibrations: pd.DataFrame | None

    @cached_property
    def obj1(self) -> pd.DataFrame:
        """Each subject's mean frontal-lateral acceleration correlation per (T_ap, segment)."""
        c = self.correlations
        if c is None or c.empty:
            return pd.DataFrame(columns=["subject", "t_ap", "segment", "correlation"])
        chosen = (c["objective"] == "frontal_lateral") & (c["signal"] == "acc") & unflagged(c)
        chosen &= c["segment"] != RIGID_BOX  # the box has Tables 4-5 of its own
        return subject_cells(c[chosen], ["t_ap", "segment"], "correlation")

    def angle_cells(self, comparison: str, keys: list[str]) -> pd.DataFrame:
        """Each subject's mean error angle of one comparison per cell (``keys``), on the body
        segments Kong's claims are about (not the rigid box).
        """
        a = self.angles
        chosen = (
            (a["comparison"] == comparison) & (a["segment"] != RIGID_BOX) if a is not None else None
        )
        if chosen is None or not chosen.any():
            return pd.DataFrame(columns=["subject", *keys, "error_angle_deg"])
        return subject_cells(a[chosen], keys, "error_angle_deg")


def cells_against(cells: pd.DataFrame, keys, value, limit, side, digits=2) -> tuple[str, str]:
    """Every cell's subject mean ``side`` ``limit`` (:func:`aceval.report.claims.beyond`): the
    verdict and the cell farthest on the wrong side, with its interval.
    """
    if cells.empty:
        return UNTESTABLE, "no cell"
    estimates = cell_estimates(cells, keys, value)
    verdicts = [beyond(r["low"], r["high"], limit, side) for _, r in estimates.iterrows()]
    worst = estimates.loc[
        estimates["mean"].idxmax() if side.startswith("<") else estimates["mean"].idxmin()
    ]
    where = " ".join(str(worst[k]) for k in keys)
    return every(verdicts), (
        f"{'largest' if side.startswith('<') else 'smallest'} cell {where}: "
        f"{interval(worst['mean'], worst['low'], worst['high'], digits)} (n {int(worst['n'])} subjects); "
        f"cells beyond / on the wrong side / undecided: {tally(verdicts)}"
    )
