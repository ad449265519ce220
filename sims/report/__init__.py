"""The report page of scenario runs and campaigns: one self-contained HTML file.

``satfmu report DIR [DIR ...]`` and :func:`write_report` read run folders (``satfmu run
--out``) and scenario campaign folders (``satfmu campaign scenario --out``) and write one page:

- a run: the metrics with pass/fail, and the time histories of the recorded signals with the
  metrics' bounds and the actuator limits drawn on the signals they apply to;
- a campaign: the statistics (pass rates with Clopper-Pearson intervals, percentiles), the
  worst samples with their dispersed values, histograms and scatter plots against the
  dispersed values, and percentile envelopes when the folder holds ``envelopes.parquet``;
- two or more campaigns (or runs): side by side;
- what was proved: the claims of the artifact each controller FMU embeds;
- the provenance: satfmu's version and commit, the FMU files' SHA-256, the machine.

Modules: :mod:`~satfmu.sims.report.folders` (reading the folders), :mod:`~satfmu.sims.report.limits`
(requirement and actuator-limit lines), :mod:`~satfmu.sims.report.figures` (matplotlib, inline SVG),
:mod:`~satfmu.sims.report.proved` (artifact claims), :mod:`~satfmu.sims.report.provenance`,
:mod:`~satfmu.sims.report.page` (the HTML, from the Jinja2 template ``page.html.j2``).
"""
from __future__ import annotations

from satfmu.sims.report.folders import ReportError
from satfmu.sims.report.page import build_report, write_report

__all__ = ["ReportError", "build_report", "write_report"]
