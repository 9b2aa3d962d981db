"""``aceval import FORMAT``: one entry point over the importers."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from ..writer import write_sheet
from .common import FormatError, ImportReport


def run_import(
    out: Path,
    format: str,
    src: str,
    sensors: str | None = None,
    subject: str = "S01",
    vicon: str | None = None,
    name: str | None = None,
) -> ImportReport:
    """Write the dataset of ``src`` (in ``format``) into the empty folder ``out``."""
    if not Path(src).exists():
        raise FormatError(f"{src} does not exist")
    if format == "hugadb":
        from .hugadb import import_hugadb

        return import_hugadb(src, out)
    from .xsens import import_xsens

    if not sensors:
        raise FormatError("xsens needs --sensors, a sheet mapping sensor IDs to IMUs and segments")
    report, imports = import_xsens(src, out, sensors, subject, name or "xsens")
    if vicon:
        from ..dataset import R_COLUMNS
        from .vicon import ground_truth_table, read_markers

        imus = pd.read_csv(out / "imus.tsv", sep="\t", dtype=str)
        table = ground_truth_table(read_markers(vicon), imports, imus, subject)
        columns = ["subject", "sensor_set", "imu", *R_COLUMNS]
        write_sheet(
            out / "ground_truth.tsv",
            columns,
            [
                [*row[:3], *(f"{v:.10f}" for v in row[3:])]
                for row in table[columns].to_numpy().tolist()
            ],
        )
        table.drop(columns=R_COLUMNS).to_csv(
            out / "ground_truth_method.tsv", sep="\t", index=False, float_format="%.4g"
        )
        report.add(
            Path(vicon).name,
            subject,
            "",
            "ground truth",
            f"{len(table)} sensors; split-half {table['split_half_deg'].max():.1f} deg at most "
            "(ground_truth_method.tsv)",
        )
    return report
