"""lumijax: differentiable, spectral radiosity lighting design for architecture, on JAX.

Data flow: config → scene → mesh and partition → transport operator → solve per network →
superposition → objectives and optimisation → reports. See ``docs/conventions.md`` for units,
frames and aim angles.

The names below are imported on first use (PEP 562): ``import lumijax`` — and so
``lumijax.cli``, whose dimmer-only rerun never needs JAX (docs/results.md, "Dimmer-only
reruns") — costs milliseconds, not the second and a half of importing JAX.
"""

from __future__ import annotations

import sys
import types
from typing import TYPE_CHECKING

from ._lazy import lazy_names
from ._version import __version__ as __version__
from .errors import (
    ConfigError as ConfigError,
    GeometryError as GeometryError,
    LumijaxError as LumijaxError,
    LumijaxWarning as LumijaxWarning,
    OutputError as OutputError,
    PhotometryError as PhotometryError,
    SolveError as SolveError,
    SpectrumError as SpectrumError,
)

if TYPE_CHECKING:
    from ._study import Study as Study, compute as compute, load_study as load_study
    from .compliance import Compliance as Compliance
    from .design import Design as Design
    from .glare import Glare as Glare, Observer as Observer
    from .optimise import Optimisation as Optimisation, optimise as optimise
    from .report import write_results as write_results
    from .results import GridResult as GridResult, Results as Results

#: public name → the module that defines it (relative to the package)
_LAZY = {
    "Study": "._study", "compute": "._study", "load_study": "._study",
    "Compliance": ".compliance", "Design": ".design", "Glare": ".glare", "Observer": ".glare",
    "Optimisation": ".optimise", "write_results": ".report",
    "GridResult": ".results", "Results": ".results",
}

__all__ = [
    "__version__", "ConfigError", "GeometryError", "LumijaxError", "LumijaxWarning",
    "OutputError", "PhotometryError", "SolveError", "SpectrumError", "optimise", *_LAZY,
]


__getattr__, __dir__ = lazy_names(__name__, globals(), _LAZY, extra=("optimise",))
del lazy_names


class _Package(types.ModuleType):
    """``lumijax.optimise`` is the function, as an eager ``from .optimise import optimise``
    made it: importing the subpackage of the same name (``lumijax.optimise._x``) sets the
    package's attribute to the subpackage, which this property ignores."""

    @property
    def optimise(self):
        from .optimise import optimise

        return optimise

    @optimise.setter
    def optimise(self, value) -> None:
        pass  # the import system binding the subpackage: the name stays the function


sys.modules[__name__].__class__ = _Package
