"""Arguments and actions checked before they reach Rust: a wrong type raises ``TypeError``,
a wrong value ``ValueError``, each naming the argument (never an ``OverflowError`` from a
conversion, nor a value silently wrapped, truncated or broadcast)."""

from __future__ import annotations

import math
import numbers
import os
from typing import Any, Optional

import numpy as np

#: Seeds are unsigned 64-bit integers (Rust's ``u64``).
SEED_MAX = 2**64 - 1


def integer(name: str, value: Any, low: int, high: int) -> int:
    """``value`` as an ``int`` from ``low`` to ``high``."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Integral, np.integer)):
        raise TypeError(f"{name} must be an integer, not {type(value).__name__} {value!r}")
    value = int(value)
    if not low <= value <= high:
        raise ValueError(f"{name} must be from {low} to {high}, not {value}")
    return value


def optional_integer(name: str, value: Any, low: int, high: int) -> Optional[int]:
    """``None``, or ``value`` checked as :func:`integer` does."""
    return None if value is None else integer(name, value, low, high)


def number(name: str, value: Any) -> float:
    """``value`` as a finite ``float``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Real, np.floating, np.integer)):
        raise TypeError(f"{name} must be a number, not {type(value).__name__} {value!r}")
    if not math.isfinite(float(value)):
        raise ValueError(f"{name} must be a finite number, not {value!r}")
    return float(value)


def text(name: str, value: Any) -> str:
    if not isinstance(value, str):
        raise TypeError(f"{name} must be a string, not {type(value).__name__} {value!r}")
    return value


def map_name(value: Any) -> str:
    """A shipped map's name or a map file's path."""
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    return text("map", value)


def seed(value: Any, name: str = "seed") -> int:
    """A match seed: an integer from 0 to 2**64 - 1."""
    return integer(name, value, 0, SEED_MAX)


def action(name: str, value: Any, n_actions: int) -> int:
    """One action index (an integer, not a float or a bool) below ``n_actions``."""
    return integer(name, value, 0, n_actions - 1)


def action_array(value: Any, rows: int, n_actions: int) -> np.ndarray:
    """One integer action per row, each below ``n_actions``: never broadcast, wrapped or
    truncated."""
    array = np.asarray(value)
    if array.ndim == 0:
        raise ValueError(f"actions must hold one action per row, shape ({rows},); a single {array!r} is not broadcast")
    if array.shape != (rows,):
        raise ValueError(f"actions must have shape ({rows},) (one per row), not {array.shape}")
    if array.dtype.kind not in "iu":
        raise TypeError(f"actions must be integers, not {array.dtype}")
    bad = np.flatnonzero((array < 0) | (array >= n_actions))
    if bad.size:
        row = int(bad[0])
        raise ValueError(f"actions[{row}] is {int(array[row])}: an action is from 0 to {n_actions - 1}")
    return array


def options(value: Any, known: Optional[tuple] = None) -> dict:
    """``reset``'s ``options``: a dict; with ``known``, whose keys are among them."""
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise TypeError(f"options must be a dict, not {type(value).__name__}")
    if known is None:
        return value
    unknown = [k for k in value if k not in known]
    if unknown:
        allowed = ", ".join(repr(k) for k in known) or "none"
        raise ValueError(f"unknown option {unknown[0]!r} (options known: {allowed})")
    return value
