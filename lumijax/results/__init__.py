"""Study results: per-grid illuminance by network, statistics, and atomic writing."""

from ._results import GridResult as GridResult, Results as Results, grid_stats as grid_stats
from ._write import write_results as write_results
