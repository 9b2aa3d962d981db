"""``aceval import FORMAT``: one entry point over the importers."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from aceval.data.writer import write_sheet
from aceval.importers.shared import FormatError, ImportReport


def run_import(out: Path, options: dict) -> ImportReport:
    """Write the dataset that ``options`` (``aceval import``'s arguments: ``format``, ``src``,
    ``sensors``, ``subject``, ``vicon``, ``name``; a lab's ``trials`` (:mod:`.xsens_lab`),
    ``mapping`` (:mod:`.table`), ``rate``, ``trim_to_shared``) describe into the empty folder
    ``out``, with its ``import_report.tsv``; returns the report.
    """
    get = options.get
    if get("format") == "table" or get("trials"):
        report = _lab(out, options)
    else:
        report = _convert(
            out,
            get("format"),
            get("src"),
            get("sensors"),
            get("subject") or "S01",
            get("vicon"),
            get("name"),
            get("rate"),
        )
    report.write(out / "import_report.tsv")
    return report


def _lab(out: Path, options: dict) -> ImportReport:
    """A lab's import: every trial of its trials.tsv (xsens, or table with a mapping)."""
    get = options.get
    if get("vicon"):
        raise FormatError("--vicon is for one trial (without --trials)")
    if not get("trials"):
        raise FormatError(
            f"{get('format')} needs --trials, the sheet of trials (docs/your_data.md)"
        )
    if get("format") == "table":
        from aceval.importers.table import import_table

        if not (get("mapping") and get("sensors")):
            raise FormatError(
                "table needs --mapping (how the files are laid out) and --sensors (docs/your_data.md)"
            )
        return import_table(
            get("src"),
            out,
            get("mapping"),
            get("trials"),
            get("sensors"),
            get("name") or "lab",
            get("rate"),
            get("trim_to_shared", False),
        )
    if get("format") != "xsens":
        raise FormatError("--trials is for xsens exports and the table import")
    from aceval.importers.xsens_lab import import_xsens_lab

    return import_xsens_lab(
        get("src"),
        out,
        get("trials"),
        get("sensors"),
        get("name") or "xsens",
        get("rate"),
        get("trim_to_shared", False),
    )


def _convert(
    out: Path,
    format: str,
    src: str,
    sensors: str | None = None,
    subject: str = "S01",
    vicon: str | None = None,
    name: str | None = None,
    rate: float | None = None,
) -> ImportReport:
    """Write the dataset of ``src`` (in ``format``) into the empty folder ``out``; the report."""
    if not Path(src).exists():
        raise FormatError(f"{src} does not exist")
    if format == "hugadb":
        from aceval.importers.hugadb import import_hugadb

        return import_hugadb(src, out)
    if format == "qmt":
        from aceval.importers.qmt import import_qmt

        if not sensors:
            raise FormatError(
                "qmt needs --sensors, a sheet naming the struct of each IMU (config/real/qmt_sensors.tsv)"
            )
        return import_qmt(src, out, sensors, subject, name or "qmt")
    if format == "gaitmap":
        from aceval.importers.gaitmap import import_gaitmap

        if not sensors:
            raise FormatError("gaitmap needs --sensors (config/real/gaitmap_feet_sensors.tsv)")
        report, truth = import_gaitmap(src, out, sensors, subject, name or "gaitmap")
        return _with_truth(out, report, truth, "mocap_sample.csv", subject)
    from aceval.importers.xsens import import_xsens

    if not sensors:
        raise FormatError("xsens needs --sensors, a sheet mapping sensor IDs to IMUs and segments")
    report, imports = import_xsens(src, out, sensors, subject, name or "xsens", rate=rate)
    if vicon:
        from aceval.importers.vicon import ground_truth_table, read_markers

        imus = pd.read_csv(out / "imus.tsv", sep="\t", dtype=str)
        table = ground_truth_table(read_markers(vicon), imports, imus, subject)
        return _with_truth(out, report, table, Path(vicon).name, subject)
    return report


def _with_truth(
    out: Path, report: ImportReport, table: pd.DataFrame, source: str, subject: str
) -> ImportReport:
    """Write ground_truth.tsv (R) and ground_truth_method.tsv (how it was made, its uncertainty)."""
    from aceval.data.contract import R_COLUMNS

    columns = ["subject", "sensor_set", "imu", *R_COLUMNS]
    write_sheet(
        out / "ground_truth.tsv",
        columns,
        [[*row[:3], *(f"{v:.10f}" for v in row[3:])] for row in table[columns].to_numpy().tolist()],
    )
    table.drop(columns=R_COLUMNS).to_csv(
        out / "ground_truth_method.tsv", sep="\t", index=False, float_format="%.4g"
    )
    flagged = table[table["flag"] != ""]
    report.add(
        source,
        subject,
        "",
        "ground truth",
        f"{len(table)} sensors; uncertainty {table['truth_uncertainty_deg'].max():.1f} deg at most; "
        f"{len(flagged)} flagged (the two methods or the uncertainty beyond 5 deg: "
        "ground_truth_method.tsv)",
    )
    return report
