"""The tracking figure's input from a rosbag2 directory (no rclpy): `tracking_data(bag_dir)`.

Reads what robot_control.record writes (mcap) and what `ros2 bag record` writes (sqlite3 .db3 or
mcap, metadata version 9), through rosbags. The loop's topics, looked up in one namespace `ns`
(found from the bag's `<ns>/joint_states`):

    <ns>/joint_states                sensor_msgs/JointState       q [rad or m]; effort = the applied
                                                                  effort [N m or N] (required)
    <ns>/<controller>/reference      sensor_msgs/JointState       q_d per joint, or x_d [m] / f_d [N]
                                                                  per task axis (the law's names)
    <ns>/<controller>/error          sensor_msgs/JointState       e = reference - actual, same names
    <ns>/robot_joint_commands        sensor_msgs/JointState       the commanded effort (plotted when
                                                                  joint_states carry no effort)
    <ns>/effort_controller/commands  std_msgs/Float64MultiArray   the same, in joint order
    <ns>/ft_sensor/wrench            geometry_msgs/WrenchStamped  measured contact force [N]
    <ns>/robot_description           std_msgs/String              URDF: prismatic joints in m
    /diagnostics                     the controller's law, force axes and effort limits

Time axis: the header stamps of joint_states (the first message of each stamp), t = stamp - first
stamp [s]; bag receive times when the stamps are all zero. Every other topic is matched by its
header stamp to the last message stamped at or before each state (zero-order hold), so in lockstep
each reference, error and wrench lands on the state it answers; NaN before its first message.

Coordinates follow the law, as the demo plots them: a joint-space law (or no controller in the
bag) plots the joints, with q_d from the reference (NaN without one) and e from ~/error (q_d - q
without one); a task-space law plots its motion axes (q = x_d - e), a 1-DOF force law the joint
with no position reference; force axes (from /diagnostics) get the measured force and f_d. The
joints plotted are the reference's (joint laws), else the commands', else joint_states'. Units:
from the URDF on robot_description, else the shipped scenario with these joint names, else rad.
A signal the bag lacks stays NaN, so the figure leaves it out (a bag of joint_states and commands
plots positions and commanded efforts only); 'sources' names the topic of each signal it has, for
the legends, and 'tau_kind' says whether tau is the applied or the commanded effort.
"""
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from robot_control import scenarios
from robot_control.tools.demo_metrics import task_units
from robot_control.units import EFFORT_UNIT

__all__ = ['tracking_data', 'BagError']

JOINT_STATE = 'sensor_msgs/msg/JointState'
TASK_AXES = ('x', 'y', 'z')


class BagError(ValueError):
    """A bag that cannot be plotted; the message names the path and what is missing."""


def bag_directory(path):
    """The rosbag2 directory of `path` (the directory, or a .mcap/.db3 file inside it); BagError if none."""
    p = Path(path)
    if not p.exists():
        raise BagError(f'bag: {p} does not exist')
    if p.is_file() and (p.parent / 'metadata.yaml').is_file():
        p = p.parent
    if not p.is_dir():
        raise BagError(f'bag: {p} is not a rosbag2 directory (give the directory holding metadata.yaml)')
    if not (p / 'metadata.yaml').is_file():
        raise BagError(f'bag: {p} is not a rosbag2 directory: no metadata.yaml in it')
    return p


def _types(bag_dir):
    """{topic: msgtype} of the bag, from its metadata; BagError if rosbags cannot open it."""
    from rosbags.rosbag2 import ReaderError
    from robot_control.tools.record import bag_info
    try:
        return {t: msgtype for t, (msgtype, _) in bag_info(bag_dir).items()}
    except ReaderError as exc:
        raise BagError(f'bag: {bag_dir}: cannot read it: {exc}') from exc


def _read(bag_dir, topics):
    """{topic: [(t_ns, msg)]} of `topics` only (other topics may hold types nobody can decode)."""
    from rosbags.rosbag2 import ReaderError
    from rosbags.serde import SerdeError
    from robot_control.tools.record import read_bag
    try:
        return read_bag(bag_dir, topics)
    except (ReaderError, SerdeError) as exc:
        raise BagError(f'bag: {bag_dir}: cannot read it: {exc}') from exc


def _namespace(types, bag_dir):
    found = sorted(t[:-len('/joint_states')] for t, ty in types.items()
                   if t.endswith('/joint_states') and ty == JOINT_STATE)
    if not found:
        raise BagError(f'bag: {bag_dir} has no joint_states topic (sensor_msgs/msg/JointState); '
                       f'its topics: {sorted(types)}')
    if len(found) > 1:
        raise BagError(f'bag: {bag_dir} holds several robots {[ns + "/joint_states" for ns in found]}: '
                       'give the namespace (--namespace)')
    return found[0]


def _stamp_ns(msg):
    return int(msg.header.stamp.sec) * 1_000_000_000 + int(msg.header.stamp.nanosec)


class Series:
    """One stamped topic held onto the state stamps `base_ns` (int64 ns): for each state, the last
    message stamped at or before it. `use_stamps=False` orders by bag receive time instead."""

    def __init__(self, messages, base_ns, use_stamps=True):
        keyed = sorted(((_stamp_ns(m) if use_stamps else t, i) for i, (t, m) in enumerate(messages)))
        self.msgs = [messages[i][1] for _, i in keyed]
        stamps = np.array([k for k, _ in keyed], dtype=np.int64)
        self.index = np.searchsorted(stamps, base_ns, side='right') - 1

    def first(self):
        return self.msgs[0]

    def column(self, getter, width):
        """(N, width) of getter(msg) per state; NaN before the first message."""
        out = np.full((self.index.size, width), np.nan)
        rows = {}
        for row, k in enumerate(self.index):
            if k >= 0:
                if k not in rows:
                    rows[k] = getter(self.msgs[k])
                out[row] = rows[k]
        return out

    def by_name(self, field, wanted):
        """(N, len(wanted)) of a JointState field for the names `wanted` (NaN where a name is missing)."""
        def get(msg):
            values = getattr(msg, field)
            if len(values) != len(msg.name):
                return [math.nan] * len(wanted)
            where = {s: i for i, s in enumerate(msg.name)}
            return [float(values[where[w]]) if w in where else math.nan for w in wanted]
        return self.column(get, len(wanted))


def _diagnostics(messages):
    """(law, force axes, {joint: effort limit}) from the newest controller statuses in /diagnostics."""
    law, force_axes, limits = None, (), {}
    for _, msg in messages:
        for st in msg.status:
            values = {kv.key: kv.value for kv in st.values}
            if st.name.endswith(': control law') and 'law' in values:
                law = values['law']
                force_axes = tuple(a for a in values.get('force_axes', '').split(',') if a)
            elif st.name.endswith(': effort saturation'):
                limits = {k.split('.', 1)[1]: float(v) for k, v in values.items() if k.startswith('effort_limit.')}
    return law, force_axes, limits


def _joint_units(joints, messages):
    """'m' for prismatic joints, 'rad' otherwise: from the last URDF on robot_description, else the
    scenario with these joints, else rad."""
    if messages:
        try:
            root = ET.fromstring(messages[-1][1].data)
            types = {j.get('name'): j.get('type') for j in root.iter('joint')}
            if all(j in types for j in joints):
                return ['m' if types[j] == 'prismatic' else 'rad' for j in joints]
        except ET.ParseError:
            pass
    from robot_control.tools.demo_experiments import JOINT_UNITS
    for sc in scenarios.SCENARIOS.values():
        if tuple(joints) == tuple(sc.joints):
            return list(JOINT_UNITS[sc.name])
    return ['rad'] * len(joints)


def _scenario_name(joints, bag_dir):
    for sc in scenarios.SCENARIOS.values():
        if tuple(joints) == tuple(sc.joints):
            return sc.name
    return Path(bag_dir).name


def _controller_topic(types, ns, leaf):
    """The JointState topic <ns>/<node>/<leaf> (the controller's ~/reference or ~/error), or None."""
    found = sorted(t for t, ty in types.items() if ty == JOINT_STATE and t.startswith(ns + '/')
                   and t.endswith('/' + leaf) and t.count('/') == ns.count('/') + 2)
    preferred = f'{ns}/controller/{leaf}'
    return preferred if preferred in found else (found[0] if found else None)


def _law_spaces(law):
    """(plots joints, uses force) of the law named `law` (None or unknown: the joints, no force)."""
    from robot_control.laws import LAWS
    if law not in LAWS:
        return True, False
    return LAWS[law].tracks != 'task', bool(LAWS[law].uses_force)


class _Bag:
    """The loop's topics of one namespace in a bag, held onto the joint_states stamps."""

    #: (topic relative to the namespace, or absolute; its type) of what a plot uses
    TOPICS = (('joint_states', JOINT_STATE), ('robot_joint_commands', JOINT_STATE),
              ('ft_sensor/wrench', 'geometry_msgs/msg/WrenchStamped'), ('robot_description', 'std_msgs/msg/String'),
              ('/diagnostics', 'diagnostic_msgs/msg/DiagnosticArray'))

    def __init__(self, bag_dir, namespace=None):
        self.dir = bag_dir
        self.types = _types(bag_dir)
        self.ns = _namespace(self.types, bag_dir) if namespace is None else '/' + namespace.strip('/')
        self.reference = _controller_topic(self.types, self.ns, 'reference')
        self.error = _controller_topic(self.types, self.ns, 'error')
        wanted = [self.name(t) for t, ty in self.TOPICS if self.types.get(self.name(t)) == ty]
        self.msgs = _read(bag_dir, wanted + [t for t in (self.reference, self.error) if t])
        states = self.topic('joint_states', JOINT_STATE)
        if not states:
            raise BagError(f'bag: {bag_dir} has no messages on {self.ns}/joint_states '
                           f'(topics: {sorted(self.types)})')
        self.use_stamps = any(_stamp_ns(m) for _, m in states)
        first = {}
        for t_ns, m in states:
            first.setdefault(_stamp_ns(m) if self.use_stamps else t_ns, (t_ns, m))
        self.base_ns = np.array(sorted(first), dtype=np.int64)
        if self.base_ns.size < 2:
            raise BagError(f'bag: {bag_dir}: {self.ns}/joint_states has {self.base_ns.size} state(s); '
                           'a plot needs at least 2')
        self.states = self.series([first[k] for k in self.base_ns])

    def name(self, relative):
        return relative if relative.startswith('/') else f'{self.ns}/{relative}'

    def topic(self, relative, msgtype):
        name = self.name(relative)
        return self.msgs.get(name) if self.types.get(name) == msgtype else None

    def series(self, messages):
        return Series(messages, self.base_ns, self.use_stamps) if messages else None


def _joints(bag, ref, joint_law):
    """Joint names to plot: the reference's (joint laws), else the commands', else joint_states'."""
    present = list(bag.states.first().name)
    cmds = bag.topic('robot_joint_commands', JOINT_STATE)
    for names in ([list(ref.first().name)] if ref is not None and joint_law else []) + \
                 ([list(cmds[0][1].name)] if cmds else []):
        if names and set(names) <= set(present):
            return names
    return present


def _effort(bag, joints):
    """(tau, 'applied' or 'commanded', its topic or None): the applied effort from joint_states,
    else the commanded effort of robot_joint_commands, else NaN."""
    tau = bag.states.by_name('effort', joints)
    if np.isfinite(tau).any():
        return tau, 'applied', bag.name('joint_states')
    cmds = bag.series(bag.topic('robot_joint_commands', JOINT_STATE))
    if cmds is None:
        return tau, 'applied', None
    return cmds.by_name('effort', joints), 'commanded', bag.name('robot_joint_commands')


def tracking_data(bag, namespace=None):
    """The input of robot_control.tools.plot.tracking_figure from the rosbag2 directory `bag` (see the
    module docstring); `namespace` picks one robot in a bag of several. BagError names what is wrong."""
    bag_dir = bag_directory(bag)
    b = _Bag(bag_dir, namespace)
    diag = b.topic('/diagnostics', 'diagnostic_msgs/msg/DiagnosticArray') or []
    law, force_axes, limits = _diagnostics(diag)
    joint_law, uses_force = _law_spaces(law)
    ref = b.series(b.msgs.get(b.reference))
    err = b.series(b.msgs.get(b.error))
    joints = _joints(b, ref, joint_law)
    units = _joint_units(joints, b.topic('robot_description', 'std_msgs/msg/String'))
    q = b.states.by_name('position', joints)
    nan = np.full_like(q, np.nan)
    tau, tau_kind, tau_topic = _effort(b, joints)
    sources = {'q': b.name('joint_states'), 'q_d': b.reference if ref is not None else None,
               'e': b.error if err is not None else None, 'tau': tau_topic}
    out = {'scenario': _scenario_name(joints, bag_dir), 't': (b.base_ns - b.base_ns[0]) * 1e-9,
           'title': ', '.join(x for x in (law, f'bag {Path(bag_dir).name}') if x),
           'tau': tau, 'tau_kind': tau_kind, 'tau_names': joints, 'tau_units': [EFFORT_UNIT[u] for u in units],
           'sources': sources}
    if limits:
        out['effort_limit'] = [limits.get(j, np.inf) for j in joints]
    motion = [a for a in ref.first().name if a not in force_axes] if ref is not None and not joint_law else []
    if joint_law:
        q_d = ref.by_name('position', joints) if ref is not None else nan
        e = err.by_name('position', joints) if err is not None else q_d - q
        out.update(joint_names=joints, units=units, q=q, q_d=q_d, e=e)
    elif motion:
        x_d = ref.by_name('position', motion)
        e = err.by_name('position', motion) if err is not None else np.full_like(x_d, np.nan)
        out.update(joint_names=motion, units=list(task_units(motion)), q=x_d - e, q_d=x_d, e=e)
        sources['q'] = f'{b.reference} \u2212 {b.error}' if err is not None else None
    else:  # a force law on a 1-DOF robot: its position, no position reference
        out.update(joint_names=joints, units=units, q=q, q_d=nan, e=nan)
    wrench = b.series(b.topic('ft_sensor/wrench', 'geometry_msgs/msg/WrenchStamped'))
    axes = [a for a in force_axes if a in TASK_AXES]
    if uses_force and axes and wrench is not None:
        out['f'] = wrench.column(lambda m: [getattr(m.wrench.force, a) for a in axes], len(axes))
        out['f_d'] = ref.by_name('position', axes) if ref is not None else None
        out['force_names'] = axes
        sources.update(f=b.name('ft_sensor/wrench'), f_d=b.reference if ref is not None else None)
    return out
