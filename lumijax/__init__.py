"""lumijax: differentiable, spectral radiosity lighting design for architecture, on JAX.

Data flow: config → scene → mesh and partition → transport operator → solve per network →
superposition → objectives and optimisation → reports. See ``docs/conventions.md`` for units,
frames and aim angles.
"""

from ._study import Study as Study, compute as compute, load_study as load_study
from ._version import __version__ as __version__
from .compliance import Compliance as Compliance
from .design import Design as Design
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
from .glare import Glare as Glare, Observer as Observer
from .optimise import Optimisation as Optimisation, optimise as optimise
from .report import write_results as write_results
from .results import GridResult as GridResult, Results as Results
