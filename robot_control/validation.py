"""Argument checks shared by the library: every failure is an ArgumentError, a ValueError that carries
the argument's name as data (`.name`) and reads '<name>: <reason>'."""
import math

import numpy as np

F64 = np.dtype(np.float64)


class ArgumentError(ValueError):
    """A bad argument: `name` is the argument (or parameter) it names, `reason` what is wrong with it.

    str() is '<name>: <reason>'. Callers that map arguments to their own names (the parameter
    engine: a config field to its parameter) read `name`, never the text.
    """

    def __init__(self, name, reason):
        self.name = name
        self.reason = str(reason)
        super().__init__(f'{name}: {self.reason}')


def is_vector(value, n):
    """True when `value` is already a float64 ndarray of shape (n,): the fast path's shape check
    (finiteness is not checked here; see finite())."""
    return type(value) is np.ndarray and value.shape == (n,) and value.dtype is F64


def finite(a):
    """True when every entry of the 1-D float array `a` is finite.

    One Python sum of the entries (a NaN or inf makes it non-finite); only when that sum is not
    finite (a NaN, an inf, or an overflow of finite entries) does numpy check entry by entry.
    """
    return math.isfinite(sum(a.tolist())) or bool(np.isfinite(a).all())


def all_finite(*arrays):
    """finite() of several 1-D float arrays at once. Python sums: a fast path that checks its
    inputs with it before any numpy arithmetic never triggers numpy's invalid-value warnings."""
    total = 0.0
    for a in arrays:
        total += sum(a.tolist())
    return math.isfinite(total) or all(bool(np.isfinite(a).all()) for a in arrays)


def float_list(value, n):
    """`value` as a new list of floats when it is a list of n finite real numbers, else None (vector()
    then names what is wrong): a command's fast path, without an array. One sum checks them all."""
    if type(value) is not list or len(value) != n:
        return None
    try:
        ok = math.isfinite(sum(value))
    except TypeError:           # a str, a complex, None ...
        return None
    return list(map(float, value)) if ok else None


def vector(name, value, n=None):
    """Return `value` as a finite float64 1-D array of length `n` (any length if n is None)."""
    if (type(value) is np.ndarray and value.dtype is F64 and value.ndim == 1
            and (n is None or value.shape[0] == n) and finite(value)):
        return value  # already what np.asarray would return: the same array
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ArgumentError(name, f'expected a sequence of numbers, got {value!r}') from exc
    if a.ndim == 0:
        a = a.reshape(1)
    if a.ndim != 1:
        raise ArgumentError(name, f'expected a 1-D array, got shape {a.shape}')
    if n is not None and a.shape[0] != n:
        raise ArgumentError(name, f'expected length {n}, got {a.shape[0]}')
    if not np.all(np.isfinite(a)):
        raise ArgumentError(name, f'expected finite values, got {a.tolist()}')
    return a


def shaped(name, value, shape):
    """Return `value` as a float64 array of exactly `shape` (entries not checked for finiteness)."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ArgumentError(name, f'expected a {shape} matrix of numbers, got {value!r}') from exc
    if a.shape != tuple(shape):
        raise ArgumentError(name, f'expected shape {tuple(shape)}, got {a.shape}')
    return a


def matrix(name, value, shape):
    """Return `value` as a finite float64 array of exactly `shape`."""
    a = shaped(name, value, shape)
    if not np.all(np.isfinite(a)):
        raise ArgumentError(name, 'expected finite values')
    return a


def scalar(name, value, *, positive=False, nonnegative=False):
    """Return `value` as a finite float, optionally required > 0 or >= 0."""
    try:
        x = float(value)
    except (TypeError, ValueError) as exc:
        raise ArgumentError(name, f'expected a number, got {value!r}') from exc
    if not math.isfinite(x):
        raise ArgumentError(name, f'expected a finite number, got {x}')
    if positive and not x > 0.0:
        raise ArgumentError(name, f'expected a positive number, got {x}')
    if nonnegative and not x >= 0.0:
        raise ArgumentError(name, f'expected a non-negative number, got {x}')
    return x


def names(name, value, expected=None):
    """Return joint names as a tuple of unique strings; if `expected` is given, the same set."""
    got = tuple(value)
    if not all(isinstance(s, str) and s for s in got):
        raise ArgumentError(name, f'expected non-empty strings, got {list(got)}')
    if len(set(got)) != len(got):
        raise ArgumentError(name, f'duplicate names in {list(got)}')
    if expected is not None and set(got) != set(expected):
        unknown = sorted(set(got) - set(expected))
        missing = sorted(set(expected) - set(got))
        raise ArgumentError(name, f'unknown {unknown}, missing {missing} (expected {list(expected)})')
    return got


def vectors(n, **named):
    """Each named value as a finite float64 (n,) array, in order; ArgumentError names the first bad one.

    Arrays that are already float64 (n,) are checked with one Python sum over all of them."""
    values = list(named.values())
    total = 0.0
    for v in values:
        if not is_vector(v, n):
            break
        total += sum(v.tolist())
    else:
        if math.isfinite(total):
            return values
    return [vector(name, value, n) for name, value in named.items()]


def optional_vector(name, value, n):
    """None, or vector(name, value, n)."""
    return None if value is None else vector(name, value, n)


def per_entry(name, value, k):
    """A finite scalar broadcast to (k,), or a finite (k,) array, or ArgumentError naming `name`."""
    if type(value) is float or type(value) is int:
        return np.full(k, scalar(name, value))
    a = vector(name, value)
    if a.shape[0] == 1 and k != 1:
        return np.full(k, a[0])
    return vector(name, a, k)


def limit_vector(name, value, n):
    """A per-entry positive bound as an (n,) array; a scalar is broadcast, +inf means unbounded."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ArgumentError(name, f'expected a number or {n} numbers, got {value!r}') from exc
    if a.ndim == 0:
        a = np.full(n, float(a))
    if a.shape != (n,):
        raise ArgumentError(name, f'expected a scalar or length {n}, got shape {a.shape}')
    if not np.all(a > 0.0):   # NaN fails the comparison
        raise ArgumentError(name, f'expected positive bounds (inf allowed), got {a.tolist()}')
    return a


def bool_mask(name, value, n):
    """`value` as a bool (n,) array, or ArgumentError naming `name` (wrong length or not booleans)."""
    a = np.asarray(value)
    if a.dtype != np.bool_:
        raise ArgumentError(name, f'expected a boolean mask, got dtype {a.dtype}')
    if a.shape != (n,):
        raise ArgumentError(name, f'expected length {n}, got shape {a.shape}')
    return a


def read_only(values, dtype=float):
    """A new read-only numpy array of `values` (dtype float, or e.g. bool), for a frozen configuration."""
    a = np.array(values, dtype=dtype)
    a.flags.writeable = False
    return a


def result(name, value):
    """`value` (a 1-D float array) if every entry is finite, else ArgumentError naming `name`: an
    overflow of finite inputs."""
    if not finite(value):
        raise ArgumentError(name, f'non-finite result {np.asarray(value).tolist()} from finite inputs')
    return value
