"""What Kong's rules read (:class:`Evidence`): the reproduced tables, the Obj 1-2 correlations, the
Obj 3-5 angles and the calibrations, as one value per subject and cell; and the comparison most
rules make, every cell against the paper's bound (:func:`against`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import pandas as pd

from aceval.calibrate.table import unflagged
from aceval.report.claims import Cells, Requirement, every_cell, labelled, subject_cells

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
    def obj1_units(self) -> pd.DataFrame:
        """Table 3's units: each subject x IMU x T_ex x T_ap's mean frontal-lateral acceleration
        correlation over the repetitions (the body segments, not the rigid box).
        """
        c = self.correlations
        keys = ["subject", "imu", "segment", "t_ex", "t_ap"]
        if c is None or c.empty:
            return pd.DataFrame(columns=[*keys, "correlation"])
        chosen = (c["objective"] == "frontal_lateral") & (c["signal"] == "acc") & unflagged(c)
        chosen &= c["segment"] != RIGID_BOX  # the box has Tables 4-5 of its own
        return c[chosen].groupby(keys, as_index=False)["correlation"].mean()

    @cached_property
    def obj1(self) -> pd.DataFrame:
        """Each subject's mean frontal-lateral acceleration correlation per (T_ap, segment)."""
        return subject_cells(self.obj1_units, ["t_ap", "segment"], "correlation")

    @cached_property
    def obj2_units(self) -> pd.DataFrame:
        """Table 6's units: subject x set x side x pair x T_ex x T_ap, repetitions averaged."""
        c = self.correlations
        keys = ["subject", "sensor_set", "side", "pair", "t_ex", "t_ap"]
        if c is None or c.empty:
            return pd.DataFrame(columns=[*keys, "correlation"])
        pairs = c[(c["objective"] == "segment_pair") & (c["signal"] == "acc") & unflagged(c)]
        return pairs.groupby(keys, as_index=False)["correlation"].mean()

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

    def set_differences(self, number: int) -> pd.DataFrame:
        """Table ``number`` (7, 8, 10): each subject's difference first set - second set per row
        (``cell``), its cells (IMUs, Table 7: sides) averaged inside it, from the committed cells
        (table ``set_test_units``): the differences the test on subjects reads.
        """
        units = self.tables.get("set_test_units")
        if units is None or units.empty or not (units["table"] == number).any():
            return pd.DataFrame(columns=["cell", "subject", "value"])
        rows = units[units["table"] == number]
        means = rows.groupby(["row", "subject"], sort=False)[["mean_a", "mean_b"]].mean()
        means = means.reset_index()
        return pd.DataFrame(
            {
                "cell": means["row"].astype(str),
                "subject": means["subject"],
                "value": means["mean_a"] - means["mean_b"],
            }
        )


def against(cells: pd.DataFrame, keys, value, limit, side, digits=2, unit="deg") -> Cells:
    """Every cell (``keys``) of subject cells, its subject mean ``side`` ``limit``."""
    long = labelled(cells, list(keys), value)
    return Cells(long, every_cell(long, Requirement.of(side, limit)), unit=unit, digits=digits)
