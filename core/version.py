"""The version of roughfriction (one place; the package and the results files read it)."""

__version__ = "0.29.0"
