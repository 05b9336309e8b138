"""The version, in one place below every subpackage (results and the report cite it).

A literal that the build reads (pyproject's ``[tool.setuptools.dynamic]``), not
``importlib.metadata``: that import alone cost 30 ms of a 0.3 s rerun."""

__version__ = "0.1.0"
