"""Effort saturation: what the actuators can deliver, and which joints hit the limit."""
import numpy as np

from robot_control import validation


def _saturate(tau, limit, out, mask):
    """out = clip(tau, -limit, limit), mask = the clipped entries (|tau| > limit); checked arrays (n,),
    out not tau itself. Returns (out, mask)."""
    np.minimum(np.maximum(tau, -limit, out=out), limit, out=out)     # np.clip's result, without its wrapper
    np.not_equal(out, tau, out=mask)
    return out, mask


def saturate(tau, limit, out=None):
    """(clip(tau, -limit, limit), |tau| > limit): tau (n,) finite, limit scalar or (n,), > 0, inf allowed.

    The mask is the `hold` argument of Integral.update (anti-windup by conditional integration).
    out: optional (tau_out float (n,), mask_out bool (n,)) written and returned instead of new arrays
    (tau_out must not be tau itself).
    """
    tau = validation.vector('tau', tau)
    n = tau.shape[0]
    limit = validation.limit_vector('limit', limit, n)
    clipped, mask = (np.empty(n), np.empty(n, dtype=bool)) if out is None else out
    return _saturate(tau, limit, clipped, mask)
