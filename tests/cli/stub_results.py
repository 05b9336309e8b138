"""Stand-in results for the result-set tests: numpy only, no compute (a helper process
forks one writer per kill point from it)."""

from __future__ import annotations

import numpy as np

BASE_LUX = {"floor": np.array([100.0, 250.0, 40.0]), "wall": np.array([7.0, 9.5])}


class Grid:
    def __init__(self, lux):
        self.illuminance_lux = lux
        self.points = np.column_stack([np.arange(len(lux)), np.zeros(len(lux)), np.zeros(len(lux))])
        self.normals = np.tile([0.0, 0.0, 1.0], (len(lux), 1))
        self.shape = None


class Stub:
    """Quacks like Results for write_results: a dimmer and the lux it gives (lux = d * base)."""
    study = "stub"
    optimisation = None
    lighting = None

    def __init__(self, dimmer):
        self.dimmer = dimmer
        self.grids = {n: Grid(dimmer * b) for n, b in BASE_LUX.items()}

    def to_dict(self):
        return {"dimmer": self.dimmer,
                "grids": {n: {"illuminance_lux": g.illuminance_lux.tolist()}
                          for n, g in self.grids.items()}}
