"""The cellgl version (one place: pyproject.toml reads it, snippet headers print it)."""
__version__ = "0.1.0"
