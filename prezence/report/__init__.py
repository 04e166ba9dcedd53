"""The post-speech report, rebuilt from a session folder's files alone.

- :func:`build_report` (``build.py``): the figures, as a JSON-ready dict.
- :func:`write_report`: ``SESSION/report/`` with ``report.html``, the PNG plots, ``report.json``,
  ``summary.txt`` and ``spoken.txt``.
- :func:`summary_phrase` (``speech.py``): what the robot says after the talk.
- :func:`report_main`: the ``prezence report SESSION_DIR`` command.

Plots need matplotlib (the ``report`` extra); everything else is standard library and numpy.
"""

from prezence.report.build import build_report, report_main, write_report
from prezence.report.speech import format_text, summary_phrase

__all__ = ["build_report", "format_text", "report_main", "summary_phrase", "write_report"]
