"""azgym's version, read from the installed package's metadata (pyproject.toml holds it)."""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("azgym")
except PackageNotFoundError:  # pragma: no cover - a source tree that was never installed
    __version__ = "0.0.0+unknown"
