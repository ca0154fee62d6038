"""The release of fw1394, written into captures, generated dissectors and results."""

__all__ = ["__version__"]

__version__ = "0.1.0"
