"""Effort saturation: what the actuators can deliver, and which joints hit the limit."""
import numpy as np

from robot_control import validation
from robot_control.laws.servo import limit_vector


def saturate(tau, limit):
    """(clip(tau, -limit, limit), |tau| > limit): tau (n,) finite, limit scalar or (n,), > 0, inf allowed.

    The mask is the `hold` argument of Integral.update (anti-windup by conditional integration).
    """
    tau = validation.vector('tau', tau)
    limit = limit_vector('limit', limit, tau.shape[0])
    return np.clip(tau, -limit, limit), np.abs(tau) > limit
