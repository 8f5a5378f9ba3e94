"""Gravity compensation: tau = g(q). The arm floats where it is put; no position servo.

Model errors show as drift (a heavier tool sags). Nothing is integrated; ~/error shows the drift
from the position held when the law started (E = q_0 - q).
"""
from robot_control import validation
from robot_control.laws.base import Law


def _gravity_compensation(model, q):
    """tau = g(q), (n,); q checked."""
    return model._g(q)


def gravity_compensation(model, q):
    """tau = g(q), (n,) N m or N; ArgumentError naming q."""
    return validation.result('tau', _gravity_compensation(model, model.check_q(q)))


class GravityCompensation(Law):
    """The registry's 'gravity_compensation': no reference is tracked, no gains, no integral."""

    name = 'gravity_compensation'
    tracks = None

    def torque(self, state, ref, err, int_E):
        return _gravity_compensation(self.model, state.q)
