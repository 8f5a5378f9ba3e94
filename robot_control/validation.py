"""Argument checks shared by the library: every failure is a ValueError naming the argument."""
import math

import numpy as np


def vector(name, value, n=None):
    """Return `value` as a finite float64 1-D array of length `n` (any length if n is None)."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f'{name}: expected a sequence of numbers, got {value!r}') from exc
    if a.ndim == 0:
        a = a.reshape(1)
    if a.ndim != 1:
        raise ValueError(f'{name}: expected a 1-D array, got shape {a.shape}')
    if n is not None and a.shape[0] != n:
        raise ValueError(f'{name}: expected length {n}, got {a.shape[0]}')
    if not np.all(np.isfinite(a)):
        raise ValueError(f'{name}: expected finite values, got {a.tolist()}')
    return a


def matrix(name, value, shape):
    """Return `value` as a finite float64 array of exactly `shape`."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f'{name}: expected a {shape} matrix of numbers, got {value!r}') from exc
    if a.shape != tuple(shape):
        raise ValueError(f'{name}: expected shape {tuple(shape)}, got {a.shape}')
    if not np.all(np.isfinite(a)):
        raise ValueError(f'{name}: expected finite values')
    return a


def scalar(name, value, *, positive=False, nonnegative=False):
    """Return `value` as a finite float, optionally required > 0 or >= 0."""
    try:
        x = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f'{name}: expected a number, got {value!r}') from exc
    if not math.isfinite(x):
        raise ValueError(f'{name}: expected a finite number, got {x}')
    if positive and not x > 0.0:
        raise ValueError(f'{name}: expected a positive number, got {x}')
    if nonnegative and not x >= 0.0:
        raise ValueError(f'{name}: expected a non-negative number, got {x}')
    return x


def names(name, value, expected=None):
    """Return joint names as a tuple of unique strings; if `expected` is given, the same set."""
    got = tuple(value)
    if not all(isinstance(s, str) and s for s in got):
        raise ValueError(f'{name}: expected non-empty strings, got {list(got)}')
    if len(set(got)) != len(got):
        raise ValueError(f'{name}: duplicate names in {list(got)}')
    if expected is not None and set(got) != set(expected):
        unknown = sorted(set(got) - set(expected))
        missing = sorted(set(expected) - set(got))
        raise ValueError(f'{name}: unknown {unknown}, missing {missing} (expected {list(expected)})')
    return got
