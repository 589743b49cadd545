"""Reports over a built dataset (above `datasets`, called by the CLI): the QC dashboard.

`write_dashboard(out)` writes OUT/qc/index.html and a page per take (`report.cache`), from what
`report.data` shapes and `report.render` writes; `app.build.dashboard_after_build(summary)` does
it after `build-dataset`.
"""

from gesturebank.report.cache import write_dashboard

__all__ = ["write_dashboard"]
