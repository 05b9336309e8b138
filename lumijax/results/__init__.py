"""Study results: per-grid illuminance by network, statistics, and atomic writing."""

from ._results import (
    CRITERIA_SLACK as CRITERIA_SLACK,
    GridResult as GridResult,
    Results as Results,
    grid_stats as grid_stats,
)
from ._write import write_results as write_results
