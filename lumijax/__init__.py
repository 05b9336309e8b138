"""lumijax: differentiable, spectral radiosity lighting design for architecture, on JAX.

Data flow: config → scene → mesh and partition → transport operator → solve per network →
superposition → objectives and optimisation → reports. See ``docs/conventions.md`` for units,
frames and aim angles.
"""

from importlib.metadata import PackageNotFoundError, version

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

try:
    __version__ = version("lumijax")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0.0.0+unknown"

from ._study import Study as Study, compute as compute, load_study as load_study
from .optimise import Optimisation as Optimisation, optimise as optimise
from .results import (
    GridResult as GridResult,
    Results as Results,
    write_results as write_results,
)
