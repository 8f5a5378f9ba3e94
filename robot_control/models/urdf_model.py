"""UrdfModel: RobotModel of any URDF robot through Pinocchio (M, C, g, fk, J, Jdot qd).

    M(q) qdd + C(q, qd) qd + g(q) = tau, with q, qd, tau ordered as the `joints` argument.

The URDF's other movable joints are locked (pin.buildReducedModel) at `q_locked` or at the
neutral configuration. Joint-space vectors hold one entry per selected joint: the angle (rad) or
the travel (m). A continuous joint is an angle here too; Pinocchio represents it by (cos, sin),
which JointMap fills in. Task space: the 3-D position of frame `tip` in the world frame; J and
Jdot qd are expressed in LOCAL_WORLD_ALIGNED axes (world axes at the tip point).
Units SI; gravity is a world vector, default (0, 0, -9.81) m/s^2.
"""
from collections.abc import Mapping

import numpy as np
import pinocchio as pin

from robot_control import units, validation
from robot_control import urdf as urdf_files
from robot_control.urdf import checks
from robot_control.models.base import TASK_SPACES, RobotModel, task_space_for
from robot_control.validation import ArgumentError

#: world axes at the tip point, the frame of J and Jdot qd
LWA = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED

#: directory of the shipped URDFs
URDF_DIR = urdf_files.DIR
#: the lookup of a URDF by name (robot_control.urdf.resolve)
resolve_urdf = urdf_files.resolve


def _parse(xml, where):
    """(Pinocchio model of URDF text, the URDF's warnings); ArgumentError naming `urdf` on anything
    malformed (robot_control.urdf.checks.check, then urdfdom's own errors)."""
    warnings = checks.check(xml, where)
    try:
        model = pin.buildModelFromXML(xml)
    except (ValueError, RuntimeError) as exc:
        raise ArgumentError('urdf', f'{where} is not a valid URDF: {exc}') from None
    _rename_joint_frames(model)
    return model, warnings


def _rename_joint_frames(model):
    """Rename the frame of a joint that shares its link's name to '<name> (joint)', in place.

    URDF keeps link and joint names apart (minitaur has a fixed joint named like a link; the SO-100
    a movable joint 'gripper' beside its link 'gripper'), but Pinocchio's lookups by name alone fail
    on such a pair. Joints keep their names (model.names; _reduced renames the locked ones for
    buildReducedModel); only the joint's frame is renamed, the link's stays.
    """
    joint_types = (pin.FrameType.JOINT, pin.FrameType.FIXED_JOINT)
    for i, frame in enumerate(model.frames):
        if frame.type in joint_types and model.existFrame(frame.name, pin.FrameType.BODY):
            frame.name = f'{frame.name} (joint)'
            model.frames[i] = frame


def _is_continuous(jm):
    """A revolute joint without limits, which Pinocchio holds as (cos, sin): nq = 2, nv = 1."""
    return jm.nq == 2 and jm.nv == 1


class JointMap:
    """Joint-space vectors (one entry per selected joint) <-> Pinocchio's configuration and tangent
    vectors. q: angles or travels; a continuous joint's angle th becomes (cos th, sin th)."""

    def __init__(self, model, joints):
        ids = [model.getJointId(name) for name in joints]
        jms = [model.joints[i] for i in ids]
        n = len(ids)
        self.iv = np.array([jm.idx_v for jm in jms])
        self.ix = np.ix_(self.iv, self.iv)
        continuous = [k for k, jm in enumerate(jms) if _is_continuous(jm)]
        simple = [k for k in range(n) if k not in continuous]
        self._simple, self._continuous = np.array(simple, dtype=int), np.array(continuous, dtype=int)
        self._iq = np.array([jms[k].idx_q for k in simple], dtype=int)
        self._iq_cos = np.array([jms[k].idx_q for k in continuous], dtype=int)
        self._q = pin.neutral(model)
        self._v = np.zeros(model.nv)
        #: vectors go to Pinocchio as they are: every joint 1-DOF, selected in Pinocchio's order
        self.identity = (not continuous and model.nq == n and model.nv == n
                         and np.array_equal(self._iq, np.arange(n)) and np.array_equal(self.iv, np.arange(n)))

    def q(self, q):
        """Pinocchio's configuration of the joint positions q (n,) (a scratch array, or q itself)."""
        if self.identity:
            return q
        self._q[self._iq] = q[self._simple]
        if self._continuous.size:
            angles = q[self._continuous]
            self._q[self._iq_cos] = np.cos(angles)
            self._q[self._iq_cos + 1] = np.sin(angles)
        return self._q

    def v(self, qd, out=None):
        """Pinocchio's tangent vector of the joint velocities (or accelerations, torques) qd (n,)."""
        if self.identity:
            return qd
        out = self._v if out is None else out
        out[self.iv] = qd
        return out

    def joint_order(self, a):
        """A Pinocchio tangent-space vector (nv,) in joint order (n,)."""
        return a if self.identity else a[self.iv]

    def matrix(self, m):
        """A Pinocchio (nv, nv) matrix in joint order (n, n)."""
        return m if self.identity else m[self.ix]

    def columns(self, m):
        """The columns (k, n) in joint order of a matrix (k, nv) over Pinocchio's tangent space."""
        return m if self.identity else m[:, self.iv]


class UrdfModel(RobotModel):
    """Rigid-body dynamics of URDF robot `urdf` restricted to `joints`, via Pinocchio.

    urdf: file path, URDF XML text, or a name robot_control.urdf.resolve knows ('kuka_iiwa/model.urdf').
    joints: joint names in the order of every joint-space vector (default: all movable joints
      in URDF tree order). Revolute, prismatic and continuous joints can be selected.
    tip: frame (link) name for fk/J/Jdot_qd; None -> no task space. A joint named like a link
      keeps the link's name for the link: its own frame is '<name> (joint)'.
    task_space: 'position' (x, y, z of the tip frame's origin, m) or 'pose' (also rx, ry, rz: its
      orientation as the rotation vector log3(R), rad; velocities are the frame's twist, angular
      velocity in world axes, and the orientation error is log3(R_d R^T), see _task_difference), or 'auto':
      pose where the arm can hold one (6 or more of the joints move the tip), else position
      (models.base.task_space_for); the attribute task_space is the one taken, tip_joints the joints
      that move the tip (in joint order).
    payload: None, or (mass kg, com (3,) m in the tip frame): a solid sphere carried by the tip
      (robot_control.urdf.with_payload, the same the simulator can carry).
    q_locked: positions of the other joints, a mapping {name: position} (rad or m; unnamed
      ones at neutral), or a full Pinocchio configuration (length of the URDF's nq, unit
      (cos, sin) pairs and quaternions).
    gravity: world gravity vector, m/s^2.
    """

    def __init__(self, urdf, joints=None, tip=None, q_locked=None, gravity=(0.0, 0.0, -units.GRAVITY),
                 task_space='position', payload=None):
        gravity = validation.vector('gravity', gravity, 3)
        if task_space not in (*TASK_SPACES, 'auto'):
            raise ArgumentError('task_space', f"expected one of {[*TASK_SPACES, 'auto']}, got {task_space!r}")
        xml, where = urdf_files.read(urdf)
        if payload is not None:
            if tip is None:
                raise ArgumentError('payload', 'a payload needs the tip that carries it')
            xml = urdf_files.with_payload(xml, tip, *payload)
        #: (mass kg, com (3,) m in the tip frame) of the payload the model carries; (0.0, zeros) for none
        self.payload = (0.0, np.zeros(3)) if payload is None else (float(payload[0]), np.array(payload[1], float))
        full, warnings = _parse(xml, where)
        self.source = where                  # file path, or 'URDF XML string'
        self.urdf_warnings = tuple(warnings)  # robot_control.urdf.checks.check's warnings
        movable = tuple(full.names[1:])
        joints = _selected(full, movable, joints)
        q_ref = _reference(full, movable, joints, q_locked)
        model = _reduced(full, [n for n in movable if n not in joints], q_ref)
        model.gravity = pin.Motion(gravity, np.zeros(3))
        self._gravity = model.gravity.vector.copy()       # (6,) spatial, world frame

        self.joint_names = joints
        self.model = model                   # pinocchio Model (treat as read-only)
        self._data = model.createData()      # scratch, reused by every call
        self._map = JointMap(model, joints)
        self._a = np.zeros(model.nv)         # scratch: accelerations or torques in Pinocchio's order
        self._zero = np.zeros(model.nv)
        n, iv = len(joints), self._map.iv
        #: flat indices into CRBA's (nv, nv) output of M in joint order (n, n), each read from the upper triangle
        #: (CRBA fills only that): M = crba(...).take(self._symmetric)
        self._symmetric = np.minimum.outer(iv, iv) * model.nv + np.maximum.outer(iv, iv)
        self._limits(model, joints)
        self.tip, self.frame_id, self.task_axes, self.tip_joints = None, None, (), ()
        if tip is not None:
            self.tip, self.frame_id = tip, _frame(model, tip)
            self._tip_joint = model.frames[self.frame_id].parentJoint     # the joint that carries the tip
            #: scratch [J | Jdot | -gravity] (6, 2n + 1) in world axes, carried to the tip frame by one product
            self._tip_world = np.empty((6, 2 * n + 1))
            self._tip_world[:, 2 * n] = -self._gravity
            moving = set(model.supports[self._tip_joint])
            self.tip_joints = tuple(j for j in joints if model.getJointId(j) in moving)
        self.task_space = task_space = task_space_for(task_space, len(self.tip_joints))
        if tip is not None:
            self.task_axes = TASK_SPACES[task_space]
        self._rows = slice(0, len(self.task_axes))    # rows of the frame's 6-D quantities in the task space

    def _limits(self, model, joints):
        iv = self._map.iv
        self._effort = _limit(model.effortLimit[iv])
        self._velocity = _limit(model.velocityLimit[iv])
        lower, upper = np.full(len(joints), -np.inf), np.full(len(joints), np.inf)
        for k, name in enumerate(joints):
            jm = model.joints[model.getJointId(name)]
            lo, hi = model.lowerPositionLimit[jm.idx_q], model.upperPositionLimit[jm.idx_q]
            if not _is_continuous(jm) and lo < hi:
                lower[k], upper[k] = lo, hi
        self._lower, self._upper = lower, upper

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
        """(lower, upper) URDF position limits per joint, rad or m, each (n,).

        -inf, inf for continuous joints and where the URDF sets no range: lower >= upper, which is
        PyBullet's "no limit" (lower > upper) or a <limit> without lower and upper (read as 0, 0)."""
        return self._lower.copy(), self._upper.copy()

    # -- the equations (RobotModel): one Pinocchio call each ------------------------------------
    def _M(self, q):
        """CRBA, symmetrized from its upper triangle (a new array)."""
        return pin.crba(self.model, self._data, self._map.q(q)).take(self._symmetric)

    def _C(self, q, qd):
        """Pinocchio's Coriolis matrix (Mdot - 2C skew; a new array, as Pinocchio returns it)."""
        return self._map.matrix(pin.computeCoriolisMatrix(self.model, self._data, self._map.q(q), self._map.v(qd)))

    def _C_qd(self, q, qd):
        """C(q, qd) qd = rnea(q, qd, 0) - g(q)."""
        pq, pv = self._map.q(q), self._map.v(qd)
        h = pin.rnea(self.model, self._data, pq, pv, self._zero).copy()
        return self._map.joint_order(h - pin.computeGeneralizedGravity(self.model, self._data, pq))

    def _g(self, q):
        """Pinocchio's generalized gravity (a new array, as Pinocchio returns it)."""
        return self._map.joint_order(pin.computeGeneralizedGravity(self.model, self._data, self._map.q(q)))

    def _inverse_dynamics(self, q, qd, qdd):
        """M qdd + C qd + g by RNEA: the same terms in one recursive pass."""
        jm = self._map
        return jm.joint_order(pin.rnea(self.model, self._data, jm.q(q), jm.v(qd), jm.v(qdd, self._a)).copy())

    def _forward_dynamics(self, q, qd, tau):
        """M^-1 (tau - C qd - g) by ABA."""
        jm = self._map
        return jm.joint_order(pin.aba(self.model, self._data, jm.q(q), jm.v(qd), jm.v(tau, self._a)).copy())

    def _Minv(self, q):
        """M^-1 by CRBA and Pinocchio's sparse Cholesky factorisation."""
        model, data = self.model, self._data
        pin.crba(model, data, self._map.q(q))
        pin.cholesky.decompose(model, data)
        return self._map.matrix(pin.cholesky.computeMinv(model, data))

    def _fk(self, q):
        """The tip frame's origin, m, (3,); with the pose task space also log3(R), rad: (6,)."""
        pin.forwardKinematics(self.model, self._data, self._map.q(q))
        return self._pose(pin.updateFramePlacement(self.model, self._data, self.frame_id))

    def _J(self, q):
        """Jacobian of the tip frame in world axes (LOCAL_WORLD_ALIGNED): linear rows, then (pose) angular, (m, n)."""
        jac = pin.computeFrameJacobian(self.model, self._data, self._map.q(q), self.frame_id, LWA)
        return self._columns(jac.reshape(6, self.model.nv)[self._rows])   # eigenpy returns (6,) when nv == 1

    def _Jdot_qd(self, q, qd):
        """The tip frame's classical acceleration at qdd = 0 (linear, then angular), world axes, (m,)."""
        pin.forwardKinematics(self.model, self._data, self._map.q(q), self._map.v(qd), self._zero)
        return self._motion(pin.getFrameClassicalAcceleration(self.model, self._data, self.frame_id, LWA))

    def payload_regressor(self, q):
        """Y (n, 4): the gravity torque of a payload on the tip is Y [m, m c_x, m c_y, m c_z], N m, for its
        mass m (kg) and centre of mass c (m, tip frame). A point mass at p + R c (tip origin p, rotation R)
        in gravity g (m/s^2, world) has  tau = -J_v^T g m + J_w^T [g]x R (m c),  J_v, J_w the tip frame's
        linear and angular Jacobians in world axes (LOCAL_WORLD_ALIGNED). Needs a tip (ArgumentError)."""
        if self.frame_id is None:
            raise ArgumentError('tip', 'the payload regressor needs the tip that carries the payload')
        q = validation.vector('q', q, self.n)
        model, data, fid = self.model, self._data, self.frame_id
        jac = pin.computeFrameJacobian(model, data, self._map.q(q), fid, LWA).reshape(6, model.nv)
        rot = data.oMf[fid].rotation
        g = model.gravity.linear
        y = np.empty((model.nv, 4))
        y[:, 0] = -jac[:3].T @ g
        y[:, 1:] = jac[3:].T @ pin.skew(g) @ rot
        return y if self._map.identity else y[self._map.iv]

    def _task(self, q, qd):
        """(x, J, Jdot qd) from one kinematics pass at (q, qd, qdd = 0)."""
        model, data, fid = self.model, self._data, self.frame_id
        pin.forwardKinematics(model, data, self._map.q(q), self._map.v(qd), self._zero)
        x = self._pose(pin.updateFramePlacement(model, data, fid))
        jdot_qd = self._motion(pin.getFrameClassicalAcceleration(model, data, fid, LWA))
        pin.computeJointJacobians(model, data)                                # placements computed above
        jac = self._columns(pin.getFrameJacobian(model, data, fid, LWA).reshape(6, model.nv)[self._rows])
        return x, jac, jdot_qd

    def _task_motion(self, q, qd, qdd):
        """(x, J qd, J qdd + Jdot qd) of the tip from one second-order kinematics pass."""
        model, data, fid = self.model, self._data, self.frame_id
        pin.forwardKinematics(model, data, self._map.q(q), self._map.v(qd), self._map.v(qdd, self._a))
        x = self._pose(pin.updateFramePlacement(model, data, fid))
        xd = self._motion(pin.getFrameVelocity(model, data, fid, LWA))
        xdd = self._motion(pin.getFrameClassicalAcceleration(model, data, fid, LWA))
        return x, xd, xdd

    def _tip_motion(self, q, qd):
        """(J, Jdot, a_g): the tip frame's Jacobian and its rate, (6, n) each, and the gravity (6,), spatial
        vectors (linear, then angular) in the tip frame at (q, qd), from one kinematics pass: the tip's
        velocity is J qd and its acceleration J qdd + Jdot qd; a_g the world's gravity carried to the frame."""
        pin.computeJointJacobiansTimeVariation(self.model, self._data, self._map.q(q), self._map.v(qd))
        n = self.n
        tip = self._tip_frames(np.empty((6, 2 * n + 1)))
        return tip[:, :n], tip[:, n:2 * n], -tip[:, 2 * n]

    def _tip_frames(self, out):
        """out (6, 2n + 1) = [J | Jdot | a_0] of _tip_motion, a_0 = -a_g (Pinocchio's base acceleration that
        stands for gravity), from the joints' Jacobians and their rates a pass left in data
        (computeJointJacobiansTimeVariation, computeCoriolisMatrix): one product carries them and the world's
        -gravity to the tip frame."""
        model, data, joint, n, world, jm = self.model, self._data, self._tip_joint, self.n, self._tip_world, self._map
        to_tip = pin.updateFramePlacement(model, data, self.frame_id).toActionMatrixInverse()    # world -> tip frame
        world[:, :n] = jm.columns(pin.getJointJacobian(model, data, joint, pin.WORLD))
        world[:, n:2 * n] = jm.columns(pin.getJointJacobianTimeVariation(model, data, joint, pin.WORLD))
        return np.dot(to_tip, world, out=out)

    def _tick_terms(self, q, qd):
        """K (6 + n, 2n + 1) = [[J, Jdot, -a_g], [M, C, g]]: _tip_motion's and _M, _C, _g at (q, qd), the tip's
        from the Coriolis matrix's pass (computeCoriolisMatrix leaves the joints' Jacobians and their rates in
        data); side by side, so that one product applies J and Jdot, M and C, and J with M, and one sum adds
        the last column: a_r = J qr_dd + Jdot qr_d - a_g beside M qr_dd + C qr_d + g."""
        n = self.n
        K = np.empty((6 + n, 2 * n + 1))
        K[6:, n:2 * n] = self._C(q, qd)
        self._tip_frames(K[:6])
        K[6:, :n] = self._M(q)
        K[6:, 2 * n] = self._g(q)
        return K

    def _dynamics_and_tip(self, q, qd):
        """(M, C, g, (J, Jdot, a_g)): _tick_terms apart."""
        K, n = self._tick_terms(q, qd), self.n
        return K[6:, :n], K[6:, n:2 * n], K[6:, 2 * n], (K[:6, :n], K[:6, n:2 * n], -K[:6, 2 * n])

    def _tip_regressor(self, q, qd, qr_d, qr_dd):
        """Y (n, 10): the share of a body carried by the tip in M(q) qr_dd + C(q, qd) qr_d + g(q), as
        Y pi with pi its inertial parameters in the tip frame (pinocchio.Inertia.toDynamicParameters:
        m; m c; Ixx, Ixy, Iyy, Ixz, Iyz, Izz about the frame's origin). C is Pinocchio's (Mdot - 2C
        skew, computeCoriolisMatrix), so Y is Slotine and Li's regressor: with qr = qd it is the
        body's share of the inverse dynamics (tip_body_regressor of _tip_motion)."""
        return tip_body_regressor(*self._tip_motion(q, qd), qd, qr_d, qr_dd)

    def tip_regressor(self, q, qd, qr_d, qr_dd):
        """_tip_regressor, checked: q, qd, qr_d, qr_dd (n,) rad, rad/s, rad/s^2 -> Y (n, 10); ArgumentError
        naming the bad argument; NotImplementedError without a tip (as fk)."""
        self._check_task()
        return self._tip_regressor(*validation.vectors(self.n, q=q, qd=qd, qr_d=qr_d, qr_dd=qr_dd))

    def _task_difference(self, x_d, x):
        """x_d - x on the position axes; log3(R_d R^T) on the orientation axes (world axes, rad)."""
        if self.task_space == 'position':
            return x_d - x
        difference = x_d - x
        difference[3:] = pin.log3(pin.exp3(x_d[3:]) @ pin.exp3(x[3:]).T)
        return difference

    @property
    def base_frame(self):
        """The URDF's root link: the frame of fk and of pose targets."""
        return self.model.frames[1].name

    def task_position(self, position, quaternion):
        """[position, log3(R(quaternion))] with the pose task space, else the position (3,)."""
        self._check_task()
        position = validation.vector('position', position, 3)
        if self.task_space == 'position':
            return position.copy()
        x, y, z, w = validation.vector('quaternion', quaternion, 4)
        return np.concatenate([position, pin.log3(pin.Quaternion(w, x, y, z).normalized().toRotationMatrix())])

    def task_pose(self, x):
        """(position, quaternion (x, y, z, w)) of a task position."""
        self._check_task()
        x = validation.vector('x', x, self.task_dim)
        if self.task_space == 'position':
            return x.copy(), np.array([0.0, 0.0, 0.0, 1.0])
        return x[:3].copy(), pin.Quaternion(pin.exp3(x[3:])).coeffs().copy()

    def _pose(self, placement):
        """The task position of a frame placement: origin (3,), then (pose) log3 of its rotation (3,)."""
        if self.task_space == 'position':
            return placement.translation.copy()
        return np.concatenate([placement.translation, pin.log3(placement.rotation)])

    def _motion(self, motion):
        """A frame's velocity or acceleration in the task space: linear (3,), then (pose) angular (3,)."""
        if self.task_space == 'position':
            return motion.linear.copy()
        return motion.vector.copy()                  # Pinocchio's order: linear, then angular

    def _columns(self, jac):
        """Columns of a (k, nv) Jacobian in joint order, (k, n) (a new array)."""
        return jac.copy() if self._map.identity else jac[:, self._map.iv]

    def __repr__(self):
        return (f'UrdfModel({self.source!r}, joints={list(self.joint_names)}, tip={self.tip!r}, '
                f'task_space={self.task_space!r})')


def tip_body_regressor(J, Jdot, a_g, qd, qr_d, qr_dd):
    """Y (n, 10) = J^T Y_b(v, v_r, a_r): a body's share, Y pi, of M(q) qr_dd + C(q, qd) qr_d + g(q) when it is
    carried by a frame with Jacobian J, its rate Jdot (6, n) and gravity a_g (6,) in that frame (UrdfModel
    ._tip_motion), with v = J qd, v_r = J qr_d, a_r = J qr_dd + Jdot qr_d - a_g (slotine_li_body_regressors);
    vectors (n,) rad/s, rad/s^2."""
    z = np.empty((1, 42))
    slotine_li_arguments(z, J @ qd, J @ qr_d, J @ qr_dd + Jdot @ qr_d - a_g)
    return J.T @ slotine_li_body_regressors(z)[0]


def slotine_li_arguments(z, v, v_r, a_r=None):
    """Fill z (k, 42), row i = [a_r_i, (v v_r^T).ravel()], the arguments of slotine_li_body_regressors: k
    evaluations at one (v, v_r) (6,) each, a_r (6,) for all or (k, 6) one per row (None: z[:, :6] holds them)."""
    if a_r is not None:
        z[:, :6] = a_r
    np.dot(v[:, None], v_r[None, :], out=z[0, 6:].reshape(6, 6))
    if len(z) > 1:
        z[1:, 6:] = z[0, 6:]


def slotine_li_body_regressors(z):
    """Y_b (k, 6, 10) = _slotine_li_body_regressor(v, v_r, a_r) per row of z (k, 42) (slotine_li_arguments),
    evaluated by its coefficients: z @ _SLOTINE_LI_COEFFICIENTS, one product for the k rows."""
    return np.dot(z, _SLOTINE_LI_COEFFICIENTS).reshape(-1, 6, 10)


def _slotine_li_body_regressor(v, v_r, a_r):
    """Y_b (6, 10): the wrench I a_r + 1/2 (v x* I v_r - I (v x v_r) + v_r x* I v) = Y_b pi of one body,
    linear in its inertial parameters pi, bilinear in its velocity v and the reference's v_r, with a_r
    the reference's acceleration (spatial vectors (6,), one frame, where pi is given). With v_r = v it is
    the Newton-Euler wrench I a + v x* I v; the 1/2 terms are Pinocchio's Coriolis matrix of one body,
    the split of v x* I v that makes Mdot - 2C skew (Slotine and Li's requirement). A(a) (6, 10): the wrench
    I a = A(a) pi of the spatial vector a, linear in a: sum_i a_i A(e_i), A(e_i) = pinocchio.bodyRegressor(0, e_i)."""
    v_m, v_r_m = pin.Motion(v), pin.Motion(v_r)
    A_a, A_v_r, A_v, A_cross = (np.array((a_r, v_r, v, v_m.cross(v_r_m).vector)) @ _BODY_REGRESSOR_BASIS).reshape(4, 6, 10)
    return A_a + 0.5 * (v_m.dualAction @ A_v_r - A_cross + v_r_m.dualAction @ A_v)


#: A(e_i) (6, 6 x 10), row i: the body regressor I x = A(x) pi of the unit spatial vector x = e_i, flattened
_BODY_REGRESSOR_BASIS = np.stack([pin.bodyRegressor(pin.Motion.Zero(), pin.Motion(e)).ravel() for e in np.eye(6)])


def _slotine_li_coefficients():
    """(42, 60): Y_b(v, v_r, a_r).ravel() = [a_r, (v v_r^T).ravel()] @ this, _slotine_li_body_regressor being
    linear in a_r and bilinear in (v, v_r): its values on unit vectors."""
    zero, unit = np.zeros(6), np.eye(6)
    rows = [_slotine_li_body_regressor(zero, zero, e) for e in unit]
    rows += [_slotine_li_body_regressor(e_i, e_j, zero) for e_i in unit for e_j in unit]
    return np.stack([r.ravel() for r in rows])


#: the coefficients of _slotine_li_body_regressor (slotine_li_body_regressors' evaluation: one product)
_SLOTINE_LI_COEFFICIENTS = _slotine_li_coefficients()


def payload_parameters(mass, com):
    """The inertial parameters pi (10,) of the payload robot_control.urdf.with_payload adds: a solid sphere of
    `mass` kg (radius PAYLOAD_RADIUS) centred at `com` (3,) m in the tip frame, in the order of
    UrdfModel.tip_regressor (m; m c; the rotational inertia about the tip frame's origin, kg m^2)."""
    mass = validation.scalar('payload.mass', mass, nonnegative=True)
    com = validation.vector('payload.com', com, 3)
    inertia = np.eye(3) * 0.4 * mass * urdf_files.PAYLOAD_RADIUS ** 2
    return pin.Inertia(mass, com, inertia).toDynamicParameters()


def _limit(values):
    """URDF limits as an array; 0 (unset) or non-finite means no limit (inf)."""
    out = np.array(values, dtype=float)
    out[~(np.isfinite(out) & (out > 0.0))] = np.inf
    return out


def _selected(full, movable, joints):
    """The selected joint names, checked: known, unique, each 1-DOF (revolute, prismatic, continuous)."""
    if not movable:
        raise ArgumentError('joints', 'the URDF has no movable joint: all its joints are fixed')
    if isinstance(joints, str):
        joints = (joints,)
    if joints is None:
        joints = movable
    try:
        joints = validation.names('joints', joints)
    except TypeError:
        raise ArgumentError('joints', f'expected a sequence of joint names, got {joints!r}') from None
    unknown = [j for j in joints if j not in movable]
    if unknown:
        raise ArgumentError('joints', f'unknown {unknown}; the URDF\'s movable joints are {list(movable)}')
    if not joints:
        raise ArgumentError('joints', 'expected at least one joint')
    for name in joints:
        jm = full.joints[full.getJointId(name)]
        if jm.nv != 1 or not (jm.nq == 1 or _is_continuous(jm)):
            raise ArgumentError('joints', f'{name!r} is a {jm.shortname()} (nq={jm.nq}, nv={jm.nv}); only '
                                          '1-DOF joints (revolute, prismatic, continuous) can be selected')
    return joints


def _reference(full, movable, joints, q_locked):
    """Pinocchio configuration of the full model that locks the other joints at q_locked."""
    q_ref = pin.neutral(full)
    if q_locked is None:
        return q_ref
    if not isinstance(q_locked, Mapping):
        q_ref = validation.vector('q_locked', q_locked, full.nq).copy()
        if not pin.isNormalized(full, q_ref, 1e-9):
            raise ArgumentError('q_locked', "a full configuration holds a unit (cos, sin) pair per continuous "
                                            'joint and unit quaternions; pinocchio.normalize(model, q) makes them so')
        return q_ref
    for name, value in q_locked.items():
        if name not in movable:
            raise ArgumentError('q_locked', f'unknown joint {name!r}; the URDF\'s movable joints are {list(movable)}')
        if name in joints:
            raise ArgumentError('q_locked', f'{name!r} is one of the selected joints, it cannot be locked')
        x = validation.scalar(f'q_locked[{name!r}]', value)
        jm = full.joints[full.getJointId(name)]
        if jm.nq == 1:
            q_ref[jm.idx_q] = x
        elif _is_continuous(jm):
            q_ref[jm.idx_q:jm.idx_q + 2] = (np.cos(x), np.sin(x))
        else:
            raise ArgumentError('q_locked', f'{name!r} is a {jm.shortname()}; give a full configuration instead')
    return q_ref


def _reduced(full, locked, q_ref):
    """The model with the joints named `locked` fixed at q_ref (pin.buildReducedModel); ArgumentError
    naming `joints` (the selection decides what is locked) when Pinocchio cannot build it. The locked
    joints of `full` are renamed after their frames (_rename_joint_frames) in place."""
    if not locked:
        return full
    ids = [full.getJointId(name) for name in locked]
    for i in ids:       # buildReducedModel finds a locked joint's frame by the joint's name
        full.names[i] = next(f.name for f in full.frames if f.parentJoint == i and f.type == pin.FrameType.JOINT)
    try:
        return pin.buildReducedModel(full, ids, q_ref)
    except (ValueError, RuntimeError) as exc:
        raise ArgumentError('joints', f'Pinocchio cannot lock the unselected joints {locked}: {exc}; '
                                      'select them too') from None


def _frame(model, tip):
    """Frame id of link `tip` (a body frame, else any frame of that name); ArgumentError naming tip."""
    links = [f.name for f in model.frames if f.type == pin.FrameType.BODY]
    if not isinstance(tip, str) or not model.existFrame(tip):
        raise ArgumentError('tip', f'unknown frame {tip!r}; the URDF\'s links are {links}')
    try:
        if model.existFrame(tip, pin.FrameType.BODY):    # a link, rather than a joint of that name
            return model.getFrameId(tip, pin.FrameType.BODY)
        return model.getFrameId(tip)
    except (ValueError, RuntimeError) as exc:            # e.g. several frames match the name
        raise ArgumentError('tip', f'frame {tip!r} is ambiguous in this URDF ({exc}); the links are {links}') \
            from None
