"""Constant external disturbances for the PyBullet world (the lecture's disturbance rejection).

The lecture writes m xdd + b xd + k x^3 + d = u: a load d on the left-hand side. Here a
disturbance is what the environment adds to the right-hand side,
    M(q) qdd + C(q, qd) qd + g(q) = tau + joint_torque + J(q)^T cartesian_force,
so the lecture's d is joint_torque = -d.
"""
import numpy as np

from robot_control.validation import ArgumentError
from robot_control import validation

KEYS = ('joint_torque', 'cartesian_force')


class Disturbance:
    """joint_torque: (n,) N m or N, added at the joints; cartesian_force: (3,) N, world axes,
    applied at the tip frame origin. None means zero. Immutable once built."""

    def __init__(self, n, joint_torque=None, cartesian_force=None, has_tip=True):
        self.joint_torque = np.zeros(n) if joint_torque is None else validation.vector('joint_torque', joint_torque, n)
        self.cartesian_force = (np.zeros(3) if cartesian_force is None
                                else validation.vector('cartesian_force', cartesian_force, 3))
        if not has_tip and np.any(self.cartesian_force != 0.0):
            raise ArgumentError('cartesian_force', 'this robot has no tip link to apply it at')
        self.joint_torque.setflags(write=False)
        self.cartesian_force.setflags(write=False)
        #: True when a non-zero joint torque / Cartesian force is set (fixed: the object is immutable)
        self.has_joint_torque = bool(np.any(self.joint_torque != 0.0))
        self.has_force = bool(np.any(self.cartesian_force != 0.0))

    @classmethod
    def from_config(cls, n, config, has_tip=True):
        """From None, a Disturbance, or a mapping with keys 'joint_torque' and/or 'cartesian_force'."""
        if config is None:
            return cls(n, has_tip=has_tip)
        if isinstance(config, Disturbance):
            return cls(n, config.joint_torque, config.cartesian_force, has_tip)
        if not hasattr(config, 'keys'):
            raise ArgumentError('disturbance', f'expected None or a mapping with keys {list(KEYS)}, got {config!r}')
        unknown = sorted(set(config) - set(KEYS))
        if unknown:
            raise ArgumentError('disturbance', f'unknown keys {unknown}; expected some of {list(KEYS)}')
        return cls(n, config.get('joint_torque'), config.get('cartesian_force'), has_tip)
