# Generated from solutions/io/__init__.py by `make modules` (every homework stubbed): do not edit by hand.
"""Data input and output: model files in, results out."""

from .model import Body, Model, ModelError, load_model
from .results import read_csv, write_csv, write_npz, write_result

__all__ = ["Body", "Model", "ModelError", "load_model", "read_csv", "write_csv", "write_npz", "write_result"]
