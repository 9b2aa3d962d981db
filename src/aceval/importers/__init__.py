"""Importers: foreign recording formats -> the dataset contract (docs/design.md, section 1).

Nothing downstream reads a foreign format. Each importer writes a complete dataset folder plus
``import_report.tsv`` (what was imported, flagged, excluded or skipped, and why).
"""

from aceval.importers.shared import FormatError, ImportReport

__all__ = ["FormatError", "ImportReport"]
