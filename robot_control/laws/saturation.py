"""Effort saturation: what the actuators can deliver, and which joints hit the limit."""
import numpy as np

from robot_control import validation
from robot_control.laws.servo import limit_vector
from robot_control.validation import finite, is_vector


def saturate(tau, limit, out=None):
    """(clip(tau, -limit, limit), |tau| > limit): tau (n,) finite, limit scalar or (n,), > 0, inf allowed.

    The mask is the `hold` argument of Integral.update (anti-windup by conditional integration).
    out: optional (tau_out float (n,), mask_out bool (n,)) written and returned instead of new arrays
    (tau_out must not be tau itself).
    """
    n = tau.shape[0] if type(tau) is np.ndarray and tau.ndim == 1 else -1
    if not (is_vector(tau, n) and finite(tau)):
        tau = validation.vector('tau', tau)
        n = tau.shape[0]
    limit = limit_vector('limit', limit, n)
    clipped, mask = (np.empty(n), np.empty(n, dtype=bool)) if out is None else out
    return clip_into(tau, limit, np.negative(limit), clipped, mask)


def clip_into(tau, limit, neg_limit, out, mask):
    """saturate() on checked arrays, no allocation: out = clip(tau, neg_limit, limit), mask = out != tau
    (the clip changed the entry <=> |tau| > limit). neg_limit = -limit; out must not be tau."""
    np.minimum(tau, limit, out=out)
    np.maximum(out, neg_limit, out=out)
    np.not_equal(out, tau, out=mask)
    return out, mask
