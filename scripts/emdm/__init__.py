"""EMDM in the browser: the Python pipeline (data, training, evaluation, export)."""

__version__ = "0.1.0"
