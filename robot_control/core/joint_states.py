"""Joint states in, by name: the controlled joints' q and qd out of any joint list (no ROS).

A state lists joints by name, in any order, maybe more than the controlled ones (a real joint_states
carries grippers, other arms, ...): the controlled joints must all be present, once each, with finite
position and velocity within +-MAX_ABS, and position must have one entry per name; velocity one entry per
name or none (a driver that sends no velocities: qd is then None, robot_control.core.velocity estimates it).
Bad input raises an ArgumentError naming the field, e.g. "position: not finite for 'r': nan".
"""
import math

import numpy as np

from robot_control import validation
from robot_control.validation import ArgumentError

#: largest magnitude accepted in a measurement or reference (rad, m, rad/s, m/s, N, ...): beyond it a
#: value is not physical but a corrupted message, and would overflow the laws or the error integral
MAX_ABS = 1e6
F64 = np.dtype(np.float64)


def sane(values):
    """True when the non-empty sequence of floats `values` is finite and within +-MAX_ABS: one Python
    sum, max and min (a NaN or an inf makes the sum non-finite)."""
    return math.isfinite(sum(values)) and max(values) <= MAX_ABS and min(values) >= -MAX_ABS


def plausible(a):
    """True when every entry of the float array `a` is finite and |a_i| <= MAX_ABS."""
    values = a.tolist()
    return not values or (max(values) <= MAX_ABS and min(values) >= -MAX_ABS)


class JointStateReader:
    """Reads q, qd of `joints` out of sensor_msgs/JointState by name, into preallocated arrays.

    read(msg) -> (q, qd): (n,) float64 arrays valid until the next read (copy them to keep
    them): internal buffers, or a robot_control.ros.cdr frame's own read-only arrays. The name ->
    index map is cached while the message's name list does not change, so a steady stream costs
    one list comparison and at most two copies per message (none for a cdr frame of arrays that
    lists exactly the controlled joints in their order). A cdr frame of floats
    (JointStateDecoder(arrays=False)) is checked on its floats, then copied: no other numpy call.
    """

    def __init__(self, joints):
        self.joints = validation.names('joints', joints)
        if not self.joints:
            raise ArgumentError('joints', 'expected at least one joint name')
        n = len(self.joints)
        self._q = np.zeros(n)
        self._qd = np.zeros(n)
        self._names = None
        self._index = None
        self._in_order = False      # the cached names are exactly `joints`, in order

    def _index_for(self, names):
        if names == self._names:
            return self._index
        seen = {}
        for i, name in enumerate(names):
            if name in seen:
                raise ArgumentError('name', f'duplicate joint {name!r}')
            seen[name] = i
        missing = [j for j in self.joints if j not in seen]
        if missing:
            raise ArgumentError('name', f'missing controlled joints {missing} (got {list(names)})')
        self._index = np.array([seen[j] for j in self.joints], dtype=np.intp)
        self._names = list(names)
        self._in_order = self._names == list(self.joints)
        return self._index

    def index(self, names):
        """Where each controlled joint is in a state's names (k,): (n,) indices (ArgumentError naming 'name')."""
        return self._index_for(names)

    def read(self, msg):
        """read_fields of a message's name, position and velocity."""
        return self.read_fields(msg.name, msg.position, msg.velocity)

    def read_fields(self, names, position, velocity):
        """(q, qd) in the order of `joints` from a state's names (k,), positions (k,) and velocities (k,) or
        none (then qd is None)."""
        k = len(names)
        if len(position) != k:
            raise ArgumentError('position', f'expected one entry per name ({k}), got {len(position)}')
        if len(velocity) != k:
            if len(velocity) == 0 and k:
                return self._positions(names, position)
            raise ArgumentError('velocity', f'expected one entry per name ({k}) or none, got {len(velocity)}')
        index = self._index_for(names)
        q, qd = self._q, self._qd
        if self._in_order and type(position) is tuple and type(velocity) is tuple:
            values = position + velocity  # a cdr frame's floats: checked before any numpy call
            try:
                ok = sane(values)
            except TypeError:             # not numbers: the array path below names them
                ok = False
            if ok:
                q[:] = position
                qd[:] = velocity
                return q, qd
        if not self._in_order:
            np.take(np.asarray(position, dtype=float), index, out=q)
            np.take(np.asarray(velocity, dtype=float), index, out=qd)
        elif (type(position) is np.ndarray and type(velocity) is np.ndarray and position.dtype is F64
              and velocity.dtype is F64 and position.ndim == velocity.ndim == 1):
            q, qd = position, velocity    # a robot_control.ros.cdr frame's read-only views: no copy
        else:
            q[:] = position               # array.array (a received message): one buffer copy
            qd[:] = velocity
        values = q.tolist() + qd.tolist()    # one Python pass: finite and plausible
        if sane(values):
            return q, qd
        if q is not self._q:
            self._q[:], self._qd[:] = q, qd
        _check('position', self.joints, self._q)
        _check('velocity', self.joints, self._qd)
        return self._q, self._qd

    def _positions(self, names, position):
        """q of a state without velocities (read_fields), checked like a full state."""
        index = self._index_for(names)
        q = self._q
        np.take(np.asarray(position, dtype=float), index, out=q)
        if not sane(q.tolist()):
            _check('position', self.joints, q)
        return q, None


def _check(field, joints, values):
    """ArgumentError naming `field` and the joints when `values` (n,) holds a non-finite or implausible entry."""
    if not np.isfinite(values).all():
        bad = [f'{joints[i]!r}: {values[i]}' for i in np.flatnonzero(~np.isfinite(values))]
        raise ArgumentError(field, f'not finite for {", ".join(bad)}')
    if not plausible(values):
        bad = [f'{joints[i]!r}: {values[i]:g}' for i in np.flatnonzero(np.abs(values) > MAX_ABS)]
        raise ArgumentError(field, f'implausible magnitude (> {MAX_ABS:g}) for {", ".join(bad)}')
