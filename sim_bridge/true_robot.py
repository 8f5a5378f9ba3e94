"""A simulated URDF robot whose links are not the URDF's: per-link mass, inertia and centre of mass
(the model-error experiment: the controller keeps the URDF, the simulator runs this). No rclpy, no pybullet.

For the link each controlled joint moves (the joint's <child> in the URDF; joints in command order):

    m_i'   = s_m,i m_i              mass_scale s_m,i > 0, dimensionless
    I_i'   = s_I,i I_i              inertia_scale s_I,i > 0: the rotational inertia about the centre
                                    of mass (<inertia>), dimensionless
    c_i'   = c_i + delta_i          com_offset delta_i, m, in the link frame (<inertial><origin xyz>)

A uniformly denser link is s_m = s_I; a lighter or heavier hand without a new shape is s_m alone.
Links not moved directly by a controlled joint (fixed to one, e.g. a flange) keep the URDF's values.
The World applies this to its checked copy of the URDF (zero <inertial>s explicit), before a probe or
payload is added, so the start-up report (sim_bridge.physics_check) compares PyBullet with Pinocchio
on the rewritten text.

Another way to the same experiment: the bridge's `urdf` may be a different file from the controller's
(e.g. the URDF with a payload, robot_control.urdf.with_payload), with the scenario's joints.
"""
import xml.etree.ElementTree as ET

import numpy as np

from robot_control import validation
from robot_control.param_table import Row, custom, gt
from robot_control.validation import ArgumentError

#: the World's `params` keys (sim_params.<key> on the bridge) of a URDF robot's link changes
KEYS = ('mass_scale', 'inertia_scale', 'com_offset')
PREFIX = 'sim_params.'
INERTIA = ('ixx', 'ixy', 'ixz', 'iyy', 'iyz', 'izz')


def _per_link(name, value, n, width=1, positive=False):
    """`value` as an (n, width) float array: empty/None = the neutral value, one entry per joint (width
    values each, flattened); ArgumentError naming sim_params.<name>."""
    neutral = np.zeros((n, width)) if not positive else np.ones((n, width))
    if value is None or len(value) == 0:
        return neutral
    a = validation.vector(PREFIX + name, value)
    if len(a) == 1 and width == 1:
        a = np.repeat(a, n)
    if len(a) != n * width:
        count = f'{width} per joint ({n * width} values)' if width > 1 else f'1 or one per joint ({n})'
        raise ArgumentError(PREFIX + name, f'expected {count}, got {len(a)}')
    if positive and np.any(a <= 0.0):
        raise ArgumentError(PREFIX + name, f'expected positive values, got {a.tolist()}')
    return a.reshape(n, width)


def changes(params, n):
    """(mass_scale (n,), inertia_scale (n,), com_offset (n, 3) m) of the World's params mapping, or None
    when they leave every link as the URDF has it."""
    mass = _per_link('mass_scale', params.get('mass_scale'), n, positive=True)[:, 0]
    inertia = _per_link('inertia_scale', params.get('inertia_scale'), n, positive=True)[:, 0]
    offset = _per_link('com_offset', params.get('com_offset'), n, width=3)
    if np.all(mass == 1.0) and np.all(inertia == 1.0) and not offset.any():
        return None
    return mass, inertia, offset


def _number(x):
    return repr(float(x))


def with_changed_links(xml, joints, mass_scale, inertia_scale, com_offset):
    """URDF text `xml` (every link with an explicit <inertial>: robot_control.urdf.checks.with_zero_inertials)
    with the child link of each of `joints` changed as the module docstring says; ArgumentError naming
    joints for a joint the URDF lacks."""
    root = ET.fromstring(xml.lstrip())
    for name, s_m, s_i, delta in zip(joints, mass_scale, inertia_scale, com_offset):
        joint = root.find(f"joint[@name='{name}']")
        if joint is None:
            raise ArgumentError('joints', f'no joint {name!r} in the URDF')
        inertial = root.find(f"link[@name='{joint.find('child').get('link')}']/inertial")
        mass, inertia, origin = inertial.find('mass'), inertial.find('inertia'), inertial.find('origin')
        mass.set('value', _number(float(mass.get('value')) * s_m))
        for key in INERTIA:
            inertia.set(key, _number(float(inertia.get(key, '0')) * s_i))
        if origin is None:
            origin = ET.SubElement(inertial, 'origin', rpy='0 0 0')
        xyz = np.array([float(v) for v in origin.get('xyz', '0 0 0').split()]) + delta
        origin.set('xyz', ' '.join(_number(v) for v in xyz))
    return ET.tostring(root, encoding='unicode')


def _check_offset(value, values):
    if value and len(value) != 3 * len(values['joints']):
        raise ArgumentError(PREFIX + 'com_offset', f'expected 3 values per joint, got {len(value)}')


def _check_scale(value, values):
    if value and len(value) not in (1, len(values['joints'])):
        raise ArgumentError('scale', f'expected 1 or one value per joint, got {len(value)}')


def rows(n):
    """The bridge's sim_params rows of a URDF robot's links (sim_bridge.bridge_params gathers them): n joints."""
    per_joint = custom('1 or one per joint', _check_scale)
    return [
        Row(PREFIX + 'mass_scale', 'double_array', (1.0,) * n,
            "Factor on the mass of the link each joint moves (the joint's URDF child), dimensionless, in joints "
            "order: a simulated robot heavier or lighter than the controller's URDF.",
            [per_joint, gt(0)], read_only=True),
        Row(PREFIX + 'inertia_scale', 'double_array', (1.0,) * n,
            'Factor on the rotational inertia about the centre of mass of the link each joint moves, '
            'dimensionless, in joints order (a uniformly denser link: the same factor as mass_scale).',
            [per_joint, gt(0)], read_only=True),
        Row(PREFIX + 'com_offset', 'double_array', (0.0,) * (3 * n),
            'Shift of the centre of mass of the link each joint moves, m, in that link\'s frame: x, y, z per '
            'joint, in joints order.', [custom('3 values per joint', _check_offset)], read_only=True),
    ]
