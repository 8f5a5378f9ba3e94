"""UrdfModel: RobotModel of any URDF robot through Pinocchio (M, C, g, fk, J, Jdot qd).

    M(q) qdd + C(q, qd) qd + g(q) = tau, with q, qd, tau ordered as the `joints` argument.

The URDF's other movable joints are locked (pin.buildReducedModel) at `q_locked` or at the
neutral configuration. Task space: the 3-D position of frame `tip` in the world frame;
J and Jdot qd are expressed in LOCAL_WORLD_ALIGNED axes (world axes at the tip point).
Units SI; gravity is a world vector, default (0, 0, -9.81) m/s^2.
"""
import xml.etree.ElementTree as ET
from collections.abc import Mapping

import numpy as np
import pinocchio as pin

from robot_control.validation import ArgumentError
from robot_control import urdf as urdf_files
from robot_control import units, validation
from robot_control.models.base import RobotModel

#: world axes at the tip point, the frame of J and Jdot qd
LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED

#: directory of the shipped URDFs
URDF_DIR = urdf_files.DIR
#: the lookup of a URDF by name (robot_control.urdf.resolve)
resolve_urdf = urdf_files.resolve


def _parse(xml, where):
    """Pinocchio model of URDF text; ValueError naming `urdf` on anything malformed."""
    try:
        root = ET.fromstring(xml)
    except ET.ParseError as exc:
        raise ArgumentError('urdf', f'{where} is not well-formed XML: {exc}') from None
    if root.tag != 'robot':
        raise ArgumentError('urdf', f'{where} has root element <{root.tag}>, expected <robot>')
    try:
        return pin.buildModelFromXML(xml)
    except (ValueError, RuntimeError) as exc:
        raise ArgumentError('urdf', f'{where} is not a valid URDF: {exc}') from None


class UrdfModel(RobotModel):
    """Rigid-body dynamics of URDF robot `urdf` restricted to `joints`, via Pinocchio.

    urdf: file path, URDF XML text, or a name resolve_urdf() knows ('kuka_iiwa/model.urdf').
    joints: joint names in the order of every joint-space vector (default: all movable joints
      in URDF tree order). Only 1-DOF joints (revolute, prismatic) can be selected.
    tip: frame (link) name for fk/J/Jdot_qd; None -> no task space.
    q_locked: positions of the other joints, a mapping {name: position} (rad or m; unnamed
      ones at neutral), or a full Pinocchio configuration (length of the URDF's nq).
    gravity: world gravity vector, m/s^2.
    """

    def __init__(self, urdf, joints=None, tip=None, q_locked=None, gravity=(0.0, 0.0, -units.GRAVITY)):
        gravity = validation.vector('gravity', gravity, 3)
        if isinstance(joints, str):
            joints = (joints,)
        if joints is not None:
            try:
                joints = validation.names('joints', joints)
            except TypeError:
                raise ArgumentError('joints', f'expected a sequence of joint names, got {joints!r}') from None
        xml, where = urdf_files.read(urdf)
        full = _parse(xml, where)
        self.source = where                  # file path, or 'URDF XML string'
        movable = tuple(full.names[1:])
        joints = movable if joints is None else joints
        unknown = [j for j in joints if j not in movable]
        if unknown:
            raise ArgumentError('joints', f'unknown {unknown}; the URDF\'s movable joints are {list(movable)}')
        if not joints:
            raise ArgumentError('joints', 'expected at least one joint')
        for name in joints:
            jm = full.joints[full.getJointId(name)]
            if jm.nq != 1 or jm.nv != 1:
                raise ArgumentError('joints', f'{name!r} is a {jm.shortname()} (nq={jm.nq}, nv={jm.nv}); '
                                 'only 1-DOF revolute/prismatic joints can be selected')
        q_ref = self._reference(full, movable, joints, q_locked)
        lock = [full.getJointId(n) for n in movable if n not in joints]
        model = pin.buildReducedModel(full, lock, q_ref) if lock else full
        model.gravity = pin.Motion(gravity, np.zeros(3))

        self.joint_names = tuple(joints)
        self.model = model                   # pinocchio Model (treat as read-only)
        self._data = model.createData()      # scratch, reused by every call
        ids = [model.getJointId(n) for n in joints]
        self._iq = np.array([model.joints[i].idx_q for i in ids])
        self._iv = np.array([model.joints[i].idx_v for i in ids])
        self._ix = np.ix_(self._iv, self._iv)
        self._q = pin.neutral(model)         # model.nq == n: every remaining joint is selected
        self._v = np.zeros(model.nv)
        self._a = np.zeros(model.nv)
        self._zero = np.zeros(model.nv)
        n = len(ids)
        # joints given in Pinocchio's order: vectors go to Pinocchio as they are, no reordering
        self._in_order = (model.nq == n and model.nv == n and np.array_equal(self._iq, np.arange(n))
                          and np.array_equal(self._iv, np.arange(n)))
        self._lower_mask = np.tril(np.ones((n, n), dtype=bool), -1)   # symmetrizes CRBA's upper triangle
        self._task_key = None                # (q bytes, qd bytes) of the cached _task() result
        self._task_out = None
        self._effort = self._limit(model.effortLimit[self._iv])
        self._lower = model.lowerPositionLimit[self._iq].copy()
        self._upper = model.upperPositionLimit[self._iq].copy()
        self._velocity = self._limit(model.velocityLimit[self._iv])

        if tip is None:
            self.tip, self.frame_id, self.task_axes = None, None, ()
        else:
            if not isinstance(tip, str) or not model.existFrame(tip):
                links = [f.name for f in model.frames if f.type == pin.FrameType.BODY]
                raise ArgumentError('tip', f'unknown frame {tip!r}; the URDF\'s links are {links}')
            body = model.existFrame(tip, pin.FrameType.BODY)   # a link, rather than a joint of that name
            fid = model.getFrameId(tip, pin.FrameType.BODY) if body else model.getFrameId(tip)
            self.tip, self.frame_id, self.task_axes = tip, fid, ('x', 'y', 'z')

    @staticmethod
    def _limit(values):
        """URDF limits as an array; 0 (unset) or non-finite means no limit (inf)."""
        out = np.array(values, dtype=float)
        out[~(np.isfinite(out) & (out > 0.0))] = np.inf
        return out

    @staticmethod
    def _reference(full, movable, joints, q_locked):
        q_ref = pin.neutral(full)
        if q_locked is None:
            return q_ref
        if isinstance(q_locked, Mapping):
            for name, value in q_locked.items():
                if name not in movable:
                    raise ArgumentError('q_locked', f'unknown joint {name!r}; '
                                     f'the URDF\'s movable joints are {list(movable)}')
                if name in joints:
                    raise ArgumentError('q_locked', f'{name!r} is one of the selected joints, it cannot be locked')
                x = validation.scalar(f'q_locked[{name!r}]', value)
                jm = full.joints[full.getJointId(name)]
                if jm.nq == 1:
                    q_ref[jm.idx_q] = x
                elif jm.nq == 2 and jm.nv == 1:   # continuous joint: (cos, sin)
                    q_ref[jm.idx_q:jm.idx_q + 2] = (np.cos(x), np.sin(x))
                else:
                    raise ArgumentError('q_locked', f'{name!r} is a {jm.shortname()}; give a full configuration instead')
            return q_ref
        return validation.vector('q_locked', q_locked, full.nq).copy()

    # -- limits ------------------------------------------------------------------------------
    @property
    def effort_limit(self):
        """URDF <limit effort> per joint, N m or N, (n,); inf where the URDF sets none (0)."""
        return self._effort.copy()

    @property
    def velocity_limit(self):
        """URDF <limit velocity> per joint, rad/s or m/s, (n,); inf where unset."""
        return self._velocity.copy()

    @property
    def position_limits(self):
        """(lower, upper) URDF position limits per joint, rad or m, each (n,)."""
        return self._lower.copy(), self._upper.copy()

    # -- helpers -----------------------------------------------------------------------------
    def _set_q(self, q):
        return self._pin_q(validation.vector('q', q, self.n))

    def _set_v(self, qd, name='qd'):
        return self._pin_v(validation.vector(name, qd, self.n))

    def _set_a(self, qdd, name='qdd'):
        return self._pin_v(validation.vector(name, qdd, self.n), self._a)

    # checked arrays (n,) -> Pinocchio's configuration / velocity vectors
    def _pin_q(self, q):
        if self._in_order:
            return q
        self._q[self._iq] = q
        return self._q

    def _pin_v(self, qd, out=None):
        if self._in_order:
            return qd
        out = self._v if out is None else out
        out[self._iv] = qd
        return out

    def _joint_order(self, a):
        """A (nv,) Pinocchio vector (a new array) in joint order."""
        return a if self._in_order else a[self._iv]

    def _require_tip(self):
        if self.frame_id is None:
            raise NotImplementedError('UrdfModel has no task space: construct it with tip=<frame name>')

    # -- joint space -------------------------------------------------------------------------
    def M(self, q):
        """Mass matrix (CRBA, symmetrized from its upper triangle), (n, n)."""
        m = pin.crba(self.model, self._data, self._set_q(q))   # a new array; upper triangle valid
        np.copyto(m, m.T, where=self._lower_mask)
        return m if self._in_order else m[self._ix]

    def C(self, q, qd):
        """Coriolis matrix (Pinocchio's, with Mdot - 2C skew), (n, n)."""
        return pin.computeCoriolisMatrix(self.model, self._data, self._set_q(q), self._set_v(qd))[self._ix]

    def C_qd(self, q, qd):
        """C(q, qd) qd = rnea(q, qd, 0) - g(q), (n,)."""
        qp, vp = self._set_q(q), self._set_v(qd)
        h = pin.rnea(self.model, self._data, qp, vp, self._zero)[self._iv]
        return h - pin.computeGeneralizedGravity(self.model, self._data, qp)[self._iv]

    def g(self, q):
        """Gravity torque g(q), (n,)."""
        return pin.computeGeneralizedGravity(self.model, self._data, self._set_q(q))[self._iv].copy()

    def inverse_dynamics(self, q, qd, qdd):
        """tau = M qdd + C qd + g by RNEA, (n,)."""
        return self._joint_order(pin.rnea(self.model, self._data, self._set_q(q), self._set_v(qd), self._set_a(qdd)))

    def forward_dynamics(self, q, qd, tau):
        """qdd = M^-1 (tau - C qd - g) by ABA, (n,)."""
        qdd = pin.aba(self.model, self._data, self._set_q(q), self._set_v(qd), self._set_a(tau, 'tau'))
        return qdd[self._iv].copy()

    # -- task space --------------------------------------------------------------------------
    def fk(self, q):
        """World position of the tip frame's origin, m, (3,)."""
        self._require_tip()
        pin.forwardKinematics(self.model, self._data, self._set_q(q))
        return pin.updateFramePlacement(self.model, self._data, self.frame_id).translation.copy()

    def J(self, q):
        """Linear Jacobian of the tip point, world axes (LOCAL_WORLD_ALIGNED), (3, n)."""
        self._require_tip()
        jac = pin.computeFrameJacobian(self.model, self._data, self._set_q(q), self.frame_id,
                                       pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        return jac.reshape(6, self.model.nv)[:3, self._iv]   # eigenpy returns (6,) when nv == 1

    def Jdot_qd(self, q, qd):
        """Jdot qd of the tip point: its classical acceleration at qdd = 0, world axes, (3,)."""
        self._require_tip()
        pin.forwardKinematics(self.model, self._data, self._set_q(q), self._set_v(qd), self._zero)
        acc = pin.getFrameClassicalAcceleration(self.model, self._data, self.frame_id,
                                                pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        return acc.linear.copy()

    # -- the laws' fast path (RobotModel): arguments already checked ------------------------------
    def _inverse_dynamics(self, q, qd, qdd):
        """RNEA, one Pinocchio call; a new (n,) array."""
        return self._joint_order(pin.rnea(self.model, self._data, self._pin_q(q), self._pin_v(qd),
                                          self._pin_v(qdd, self._a)))

    def _task(self, q, qd):
        """(x, J, Jdot_qd) from one kinematics pass, cached for the last (q, qd) (read-only arrays)."""
        key = (q.tobytes(), qd.tobytes())
        if key == self._task_key:
            return self._task_out
        self._require_tip()
        model, data, fid = self.model, self._data, self.frame_id
        pq = self._pin_q(q)
        pin.forwardKinematics(model, data, pq, self._pin_v(qd), self._zero)   # qdd = 0: the bias Jdot qd
        x = pin.updateFramePlacement(model, data, fid).translation.copy()
        jdot_qd = pin.getFrameClassicalAcceleration(model, data, fid, LWA).linear.copy()
        pin.computeJointJacobians(model, data)                                # placements computed above
        jac = pin.getFrameJacobian(model, data, fid, LWA).reshape(6, model.nv)[:3]
        jac = jac if self._in_order else jac[:, self._iv]
        for a in (x, jac, jdot_qd):
            a.flags.writeable = False
        self._task_out = (x, jac, jdot_qd)
        self._task_key = key
        return self._task_out

    def _task_motion(self, q, qd, qdd):
        """(x, J qd, J qdd + Jdot qd) of the tip from one second-order kinematics pass."""
        self._require_tip()
        model, data, fid = self.model, self._data, self.frame_id
        pin.forwardKinematics(model, data, self._pin_q(q), self._pin_v(qd), self._pin_v(qdd, self._a))
        x = pin.updateFramePlacement(model, data, fid).translation.copy()
        xd = pin.getFrameVelocity(model, data, fid, LWA).linear.copy()
        xdd = pin.getFrameClassicalAcceleration(model, data, fid, LWA).linear.copy()
        return x, xd, xdd

    def _Minv(self, q):
        """M^-1 by CRBA and Pinocchio's sparse Cholesky, (n, n)."""
        model, data = self.model, self._data
        pin.crba(model, data, self._pin_q(q))
        pin.cholesky.decompose(model, data)
        minv = pin.cholesky.computeMinv(model, data)
        return minv if self._in_order else minv[self._ix]

    def __repr__(self):
        return f'UrdfModel({self.source!r}, joints={list(self.joint_names)}, tip={self.tip!r})'
