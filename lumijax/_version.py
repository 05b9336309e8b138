"""The installed version, in one place below every subpackage (results and the report cite it)."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("lumijax")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0.0.0+unknown"
