"""Study results: per-grid illuminance by network and statistics (writing lives in ``lumijax.report``)."""

from ._results import (
    CRITERIA_SLACK as CRITERIA_SLACK,
    GridResult as GridResult,
    Results as Results,
    grid_stats as grid_stats,
)
