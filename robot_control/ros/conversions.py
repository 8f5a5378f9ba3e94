"""Message <-> array conversions: the only module that reads or writes message fields.

Like cv_bridge: every function turns one ROS message into float64 numpy arrays (or back),
joints matched by name, never by index. Bad input raises ValueError whose message starts
with the offending field, e.g. "position['r']: not finite (nan)"; the node turns that into a
rejected-input diagnostic.

Conventions
- Times are integer nanoseconds (`stamp_to_ns`), exact; callers convert to seconds.
- JointState in: the controlled `joints` must all be present, once each, with finite position
  and velocity; `position` and `velocity` must have one entry per name. Names that are not
  controlled are ignored (a real `joint_states` carries grippers, other arms, ...) and so are
  their values. `effort` is not read.
- Wrench: the force components along the task axes named 'x', 'y', 'z' (the torque part is
  not used by the laws here). The force is the one the robot exerts on the environment.
"""
import array
import math

import numpy as np
from builtin_interfaces.msg import Duration, Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped, WrenchStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

from robot_control import units, validation
from robot_control.core.joint_states import F64, MAX_ABS, JointStateReader, plausible, sane  # noqa: F401 (JointStateReader: read here)
from robot_control.validation import ArgumentError
from robot_control.units import NS_PER_S

#: the six components of a wrench (force, then torque) and of a pose (position, then rotation vector)
WRENCH_AXES = ('x', 'y', 'z', 'rx', 'ry', 'rz')


# -- time --------------------------------------------------------------------------------------
def stamp_to_ns(stamp):
    """builtin_interfaces/Time (or Duration) -> integer nanoseconds."""
    return units.stamp_ns(int(stamp.sec), int(stamp.nanosec))


def ns_to_stamp(ns, out=None):
    """Integer nanoseconds (>= 0) -> builtin_interfaces/Time; fills `out` in place when given."""
    ns = int(ns)
    if ns < 0:
        raise ArgumentError('ns', f'expected a non-negative time, got {ns}')
    out = Time() if out is None else out
    out.sec, out.nanosec = units.split_ns(ns)
    return out


def duration_to_s(duration):
    """builtin_interfaces/Duration -> float seconds."""
    return int(duration.sec) + int(duration.nanosec) * 1e-9


def s_to_duration(seconds):
    """Float seconds -> builtin_interfaces/Duration rounded to the nanosecond."""
    seconds = validation.scalar('seconds', seconds)
    sec, nanosec = units.split_ns(units.to_ns(seconds))
    return Duration(sec=sec, nanosec=nanosec)


# -- joint states ------------------------------------------------------------------------------
def joint_state(names, stamp_ns=0, position=(), velocity=(), effort=(), frame_id='', out=None):
    """sensor_msgs/JointState with the given names and float arrays (empty fields stay empty)."""
    msg = JointState() if out is None else out
    msg.header.frame_id = frame_id
    ns_to_stamp(stamp_ns, msg.header.stamp)
    msg.name = list(names)
    msg.position = _float_array(position)
    msg.velocity = _float_array(velocity)
    msg.effort = _float_array(effort)
    return msg


def _float_array(values):
    """array.array('d') of `values` (what a float64[] message field holds): one copy, no list."""
    return array.array('d', np.asarray(values, dtype=float).tobytes())


def joint_state_arrays(msg):
    """(names tuple, stamp_ns, position, velocity, effort) of a JointState, unvalidated, by index."""
    return (tuple(msg.name), stamp_to_ns(msg.header.stamp), np.asarray(msg.position, dtype=float),
            np.asarray(msg.velocity, dtype=float), np.asarray(msg.effort, dtype=float))


def effort_array(tau, out=None):
    """std_msgs/Float64MultiArray of the efforts in `joints` order (forward effort controller)."""
    msg = Float64MultiArray() if out is None else out
    msg.data = _float_array(tau)
    return msg


def effort_array_values(msg):
    """The data of a Float64MultiArray as a float64 array."""
    return np.asarray(msg.data, dtype=float)


# -- trajectories ------------------------------------------------------------------------------
class TrajectoryGoal:
    """A checked JointTrajectory in controller order: float64 arrays, times in s.

    stamp_ns: header.stamp (0 = start when received); times (k,) time_from_start, increasing, the
    first >= 0 (k = 0: an empty trajectory, which cancels the motion); positions (k, n), NaN in the
    columns of joints the message leaves out (allow_partial_joints_goal); velocities, accelerations
    (k, n) or None; given (n,) bool, the joints the message names.
    """

    __slots__ = ('stamp_ns', 'times', 'positions', 'velocities', 'accelerations', 'given')

    def __init__(self, stamp_ns, times, positions, velocities=None, accelerations=None, given=None):
        self.stamp_ns = stamp_ns
        self.times = times
        self.positions = positions
        self.velocities = velocities
        self.accelerations = accelerations
        self.given = np.ones(positions.shape[1], dtype=bool) if given is None else given

    @property
    def empty(self):
        return self.times.shape[0] == 0


def _point_field(points, field, n, columns, required):
    """(k, n) array of `field` from every point, in the controller's joint order (NaN in the columns of
    joints the message does not name), or None when no point gives the field."""
    names = len(columns)
    sizes = {len(getattr(p, field)) for p in points}
    if sizes == {0} and not required:
        return None
    if sizes != {names}:
        for i, p in enumerate(points):
            if len(getattr(p, field)) != names:
                what = 'one entry per joint name' if required else 'none, or one entry per joint name in every point'
                raise ArgumentError(f'points[{i}].{field}', f'expected {what} ({names}), got {len(getattr(p, field))}')
    out = np.full((len(points), n), np.nan)
    for i, p in enumerate(points):
        row = np.asarray(getattr(p, field), dtype=float)
        if not np.isfinite(row).all():
            raise ArgumentError(f'points[{i}].{field}', f'not finite {row.tolist()}')
        if not plausible(row):
            raise ArgumentError(f'points[{i}].{field}', f'implausible magnitude (> {MAX_ABS:g}) {row.tolist()}')
        out[i, columns] = row
    return out


def _times(points):
    """time_from_start of every point, s: the first >= 0, each later one after the one before."""
    times = np.array([duration_to_s(p.time_from_start) for p in points])
    if times.size and times[0] < 0.0:
        raise ArgumentError('points[0].time_from_start', f'expected >= 0 s, got {times[0]:g} s')
    steps = np.diff(times)
    if np.any(steps <= 0.0):
        i = int(np.flatnonzero(steps <= 0.0)[0]) + 1
        raise ArgumentError(f'points[{i}].time_from_start', f'not after points[{i - 1}] '
                                                            f'({times[i]:g} s <= {times[i - 1]:g} s)')
    return times


def trajectory_goal(msg, joints, allow_partial=False):
    """Check a trajectory_msgs/JointTrajectory against `joints` -> TrajectoryGoal (joints order).

    Like joint_trajectory_controller: names in any order, no unknown or duplicate name, every
    controlled joint named unless allow_partial (the others then hold); time_from_start increasing,
    the first point may be at 0 s (a planner's current state); finite values; velocities and
    accelerations either absent from every point or given for every named joint in every point.
    No points: an empty trajectory (cancel the motion, hold the current position).
    """
    joints = tuple(joints)
    names = list(msg.joint_names)
    if len(set(names)) != len(names):
        raise ArgumentError('joint_names', f'duplicate names in {names}')
    unknown = sorted(set(names) - set(joints))
    missing = sorted(set(joints) - set(names))
    if unknown or (missing and not allow_partial):
        raise ArgumentError('joint_names', f'unknown {unknown}, missing {missing} (controlled joints {list(joints)}'
                                           f'{"" if allow_partial else "; allow_partial_joints_goal is false"})')
    points = msg.points
    n = len(joints)
    columns = np.array([joints.index(name) for name in names], dtype=np.intp)
    given = np.zeros(n, dtype=bool)
    given[columns] = True
    times = _times(points)
    positions = _point_field(points, 'positions', n, columns, required=True) if points else np.zeros((0, n))
    velocities = _point_field(points, 'velocities', n, columns, required=False) if points else None
    accelerations = _point_field(points, 'accelerations', n, columns, required=False) if points else None
    if accelerations is not None and velocities is None:
        raise ArgumentError('points[0].accelerations', 'given without velocities')
    return TrajectoryGoal(stamp_to_ns(msg.header.stamp), times, positions, velocities, accelerations, given)


def joint_trajectory(joints, times, positions, velocities=None, accelerations=None, stamp_ns=0):
    """trajectory_msgs/JointTrajectory from per-point rows: times (k,) s, positions (k, n), ...

    Rows are written as given (not validated), so malformed messages can be built for tests.
    """
    msg = JointTrajectory()
    ns_to_stamp(stamp_ns, msg.header.stamp)
    msg.joint_names = list(joints)
    for i, t in enumerate(times):
        p = JointTrajectoryPoint()
        p.time_from_start = s_to_duration(t)
        p.positions = [float(v) for v in positions[i]]
        if velocities is not None:
            p.velocities = [float(v) for v in velocities[i]]
        if accelerations is not None:
            p.accelerations = [float(v) for v in accelerations[i]]
        msg.points.append(p)
    return msg


# -- wrenches ----------------------------------------------------------------------------------
def _axis_indices(axes):
    """Index of each task axis in a wrench's six components (force x, y, z, then torque rx, ry, rz)."""
    try:
        return [WRENCH_AXES.index(a) for a in axes]
    except ValueError:
        raise ArgumentError('axes', f'task axes {list(axes)} must be named from {list(WRENCH_AXES)} '
                                    'to be read from a wrench') from None


def _six(msg):
    f, t = msg.wrench.force, msg.wrench.torque
    return (f.x, f.y, f.z, t.x, t.y, t.z)


def wrench_force(msg, axes, out=None):
    """The components of a geometry_msgs/WrenchStamped (or a robot_control.ros.cdr.WrenchFrame) along task
    `axes`: force on 'x'|'y'|'z' (N), torque on 'rx'|'ry'|'rz' (N m), as a float64 array (into `out` if
    given); ArgumentError naming wrench.force or wrench.torque when one of those components is not finite
    or beyond +-MAX_ABS."""
    idx = _axis_indices(axes)
    six = _six(msg)
    values = [six[i] for i in idx]
    if values and not sane(values):
        for part, lo, unit in (('wrench.force', 0, 'N'), ('wrench.torque', 3, 'N m')):
            mine = [six[i] for i in idx if lo <= i < lo + 3]
            if not all(map(math.isfinite, mine)):
                raise ArgumentError(part, f'not finite {list(six[lo:lo + 3])}')
            if mine and not sane(mine):
                raise ArgumentError(part, f'implausible magnitude (> {MAX_ABS:g} {unit}) {list(six[lo:lo + 3])}')
    if out is None:
        return np.array(values, dtype=F64)
    out[:] = values
    return out


def wrench_stamped(force=(0.0, 0.0, 0.0), torque=(0.0, 0.0, 0.0), stamp_ns=0, frame_id=''):
    """geometry_msgs/WrenchStamped from a force (3,) N and torque (3,) N m."""
    msg = WrenchStamped()
    ns_to_stamp(stamp_ns, msg.header.stamp)
    msg.header.frame_id = frame_id
    fx, fy, fz = (float(v) for v in validation.vector('force', force, 3))
    tx, ty, tz = (float(v) for v in validation.vector('torque', torque, 3))
    msg.wrench.force.x, msg.wrench.force.y, msg.wrench.force.z = fx, fy, fz
    msg.wrench.torque.x, msg.wrench.torque.y, msg.wrench.torque.z = tx, ty, tz
    return msg


def wrench_along(axes, values, stamp_ns=0, frame_id=''):
    """WrenchStamped with `values` on task `axes` (force 'x'|'y'|'z', torque 'rx'|'ry'|'rz'), 0 elsewhere."""
    values = validation.vector('values', values, len(axes))
    six = [0.0] * 6
    for i, v in zip(_axis_indices(axes), values):
        six[i] = float(v)
    return wrench_stamped(six[:3], six[3:], stamp_ns=stamp_ns, frame_id=frame_id)


# -- poses -----------------------------------------------------------------------------------------
#: a quaternion's norm outside this range is not a rotation given with rounding: refused
QUATERNION_NORM = (0.5, 2.0)


def check_base_frame(msg, base_frame):
    """ArgumentError naming header.frame_id unless the stamped message `msg` is in `base_frame` (or '')."""
    frame = msg.header.frame_id
    if frame not in ('', base_frame):
        raise ArgumentError('header.frame_id', f"expected the model's base frame {base_frame!r} (or ''), "
                                               f'got {frame!r}')


def pose_target(msg, base_frame):
    """geometry_msgs/PoseStamped in the model's base frame -> (position (3,) m, unit quaternion (4,) x, y,
    z, w); the model turns them into its task position (RobotModel.task_position).

    header.frame_id '' or `base_frame`; a quaternion of norm in QUATERNION_NORM is normalised, any
    other is refused; finite, plausible values. ArgumentError naming the field."""
    check_base_frame(msg, base_frame)
    p, o = msg.pose.position, msg.pose.orientation
    position = np.array([p.x, p.y, p.z])
    if not (np.isfinite(position).all() and plausible(position)):
        raise ArgumentError('pose.position', f'expected finite values within {MAX_ABS:g} m, got {position.tolist()}')
    quat = np.array([o.x, o.y, o.z, o.w])
    # entries beyond 2 make the norm exceed QUATERNION_NORM anyway: refused before they could overflow
    norm = float(np.linalg.norm(quat)) if np.isfinite(quat).all() and np.abs(quat).max() <= 2.0 else float('nan')
    if not QUATERNION_NORM[0] <= norm <= QUATERNION_NORM[1]:
        raise ArgumentError('pose.orientation', f'not a rotation: quaternion {quat.tolist()} of norm {norm:g}')
    return position, quat / norm


def pose_stamped(position, quaternion=(0.0, 0.0, 0.0, 1.0), stamp_ns=0, frame_id=''):
    """geometry_msgs/PoseStamped of a position (3,) m and a quaternion (x, y, z, w)."""
    msg = PoseStamped()
    ns_to_stamp(stamp_ns, msg.header.stamp)
    msg.header.frame_id = frame_id
    p, o = msg.pose.position, msg.pose.orientation
    p.x, p.y, p.z = (float(v) for v in position)
    o.x, o.y, o.z, o.w = (float(v) for v in quaternion)
    return msg


# -- diagnostics -------------------------------------------------------------------------------
LEVELS = {'OK': DiagnosticStatus.OK, 'WARN': DiagnosticStatus.WARN,
          'ERROR': DiagnosticStatus.ERROR, 'STALE': DiagnosticStatus.STALE}


def _text(value):
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else str(value)
    return str(value)


def diagnostic_status(name, level, message, values=(), hardware_id=''):
    """diagnostic_msgs/DiagnosticStatus; level 'OK'|'WARN'|'ERROR'|'STALE'; values (key, value) pairs."""
    status = DiagnosticStatus()
    status.level = LEVELS[level]
    status.name = name
    status.message = message
    status.hardware_id = hardware_id
    items = values.items() if isinstance(values, dict) else values
    status.values = [KeyValue(key=str(k), value=_text(v)) for k, v in items]
    return status


def diagnostic_array(statuses, stamp_ns):
    """diagnostic_msgs/DiagnosticArray of `statuses` stamped `stamp_ns`."""
    msg = DiagnosticArray()
    ns_to_stamp(stamp_ns, msg.header.stamp)
    msg.status = list(statuses)
    return msg


def diagnostic_values(status):
    """(level name, message, {key: value}) of a DiagnosticStatus."""
    level = {v: k for k, v in LEVELS.items()}[status.level]
    return level, status.message, {kv.key: kv.value for kv in status.values}
