"""Groups of a tidy table as positions, found in one pass: per-group work then reads NumPy slices
of the table's columns instead of selecting a pandas frame per group (a selection costs about a
millisecond; a calibration job asks for thousands).
"""

from __future__ import annotations

import numpy as np
import pandas as pd


def group_positions(table: pd.DataFrame, keys: list[str]) -> list[tuple[tuple, np.ndarray]]:
    """``[(key, positions), ...]``: each group of ``table`` by the columns ``keys``, in the order
    of its first row, with the positions (0-based, in table order) of its rows: what
    ``table.groupby(keys, sort=False)`` iterates, as ``table.iloc[positions]``.
    """
    codes = table.groupby(keys, sort=False).ngroup().to_numpy() if len(table) else []
    order = np.argsort(codes, kind="stable")
    order = order[np.asarray(codes)[order] >= 0]  # a row with a missing key is in no group
    if not len(order):
        return []
    starts = np.r_[0, np.flatnonzero(np.diff(codes[order])) + 1]
    found = table[keys].to_numpy(object)[order[starts]]
    return list(zip(map(tuple, found), np.split(order, starts[1:])))
