"""What both simulated worlds share, engine-free (no pybullet, no mujoco, no rclpy): the build specification
of a world from its arguments (scenario, params, URDF, joints, q0, surface, tip, payload), resolved once into a
checked URDF copy and a WorldSpec; the physics step as whole nanoseconds; the URDF's travel and inertials.

sim_bridge.world.World (PyBullet) and sim_bridge.mujoco_world.MujocoWorld (MuJoCo) build their robot from the
same WorldSpec, so both simulate the same URDF text.
"""
import os
from dataclasses import dataclass
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin

from robot_control.validation import ArgumentError
from robot_control import scenarios, units, validation
from robot_control import urdf as urdf_files
from robot_control.urdf import checks
from robot_control.models import make_model, urdf_gen
from sim_bridge import surfaces, true_robot

#: brake holding force where the URDF sets no effort limit, N m or N
UNLIMITED_BRAKE = 1.0e6


@dataclass
class WorldSpec:
    """Everything needed to (re)build the world: resolved once, used by every build."""

    urdf: str                 # file PyBullet loads
    joints: tuple
    q0: np.ndarray
    gravity: float            # m/s^2, along world -z
    tip: str                  # link name or None
    closed_form: bool
    task_axes: tuple
    surface: object           # scenarios.Surface or None
    surface_damping: float    # N s/m
    spring: tuple             # (k N/m^3, b N s/m) of mass_spring_cubic, or None
    warnings: list            # robot_control.urdf.checks.check's warnings about the URDF


def scenario_of(scenario):
    if scenario is None or isinstance(scenario, scenarios.Scenario):
        return scenario
    if isinstance(scenario, str):
        return scenarios.get(scenario)
    raise ArgumentError('scenario', f'expected a name, a Scenario or None, got {scenario!r}')


def _truth(sc, params):
    """(physical parameters, closed-form model or None, gravity m/s^2) of the simulated robot."""
    if params is not None and not hasattr(params, 'keys'):
        raise ArgumentError('params', f'expected a mapping of physical parameters, got {params!r}')
    params = dict(params or {})
    base = dict(sc.params) if sc is not None else {}
    truth, model = {**base, **params}, None
    if sc is None or sc.model == 'urdf':
        unknown = sorted(set(params) - {'gravity', *true_robot.KEYS})
        if unknown:
            raise ArgumentError('params', f'unknown {unknown} for a URDF robot; expected some of '
                                          f"{['gravity', *true_robot.KEYS]}")
    else:
        try:
            model = make_model(sc.model, **truth)
        except ValueError as exc:
            raise ArgumentError('params', f'{exc}') from None
    gravity = validation.scalar('params.gravity', truth.get('gravity', units.GRAVITY), nonnegative=True)
    return truth, model, gravity


def _surface(sc, surface):
    if surface is True:
        return sc.surface if sc is not None else None
    if surface is False or surface is None:
        return None
    return surfaces.check_surface(surface)


def _simulated_copy(path, tmpdir):
    """(copy of the URDF at `path` as PyBullet must load it, the URDF's warnings): checked
    (robot_control.urdf.checks.check), its meshes found (absolute file:// URIs; ArgumentError naming
    `urdf` for one found nowhere) and an explicit zero <inertial> for every link without one, so
    that PyBullet simulates such a link massless, as the URDF (and the controller's model) means."""
    xml, where = urdf_files.read(path)
    warnings = checks.check(xml, where)
    xml = urdf_files.with_absolute_meshes(xml, os.path.dirname(os.path.abspath(path)))
    out = os.path.join(tmpdir, 'simulated.urdf')
    with open(out, 'w', encoding='utf-8') as f:
        f.write(checks.with_zero_inertials(xml))
    return out, warnings


def _with_payload(path, tip, payload, tmpdir):
    """A copy of the URDF at `path` whose tip carries the payload (robot_control.urdf.with_payload)."""
    if tip is None:
        raise ArgumentError('payload', 'needs a tip link (tip=...)')
    xml, _ = urdf_files.read(path)
    xml = urdf_files.with_absolute_meshes(xml, os.path.dirname(os.path.abspath(path)))
    out = os.path.join(tmpdir, 'with_payload.urdf')
    with open(out, 'w', encoding='utf-8') as f:
        f.write(urdf_files.with_payload(xml, tip, *payload))
    return out


def _changed_links(path, joints, changes, tmpdir):
    """The URDF at `path` with its links changed (sim_bridge.true_robot), or `path` when `changes` is None."""
    if changes is None:
        return path
    with open(path, encoding='utf-8') as f:
        xml = true_robot.with_changed_links(f.read(), joints, *changes)
    out = os.path.join(tmpdir, 'changed_links.urdf')
    with open(out, 'w', encoding='utf-8') as f:
        f.write(xml)
    return out


def resolve(sc, params, urdf, joints, q0, surface, tip, surface_damping, payload, tmpdir):
    """The build specification (WorldSpec); every check that can fail before an engine runs."""
    truth, model, gravity = _truth(sc, params)
    closed_form = model is not None
    if urdf is not None:
        path = urdf_files.resolve(urdf)
    elif sc is None:
        raise ArgumentError('urdf', 'required when scenario is None')
    elif closed_form and truth != dict(sc.params):
        path = urdf_gen.write_urdf(os.path.join(tmpdir, f'{sc.model}.urdf'), sc.model, **truth)
    else:
        path = urdf_files.resolve(sc.urdf or sc.model)
    path, warnings = _simulated_copy(path, tmpdir)
    if joints is None and sc is None:
        raise ArgumentError('joints', 'required when scenario is None')
    joints = validation.names('joints', sc.joints if joints is None else joints)
    if not joints:
        raise ArgumentError('joints', 'expected at least one joint')
    if not closed_form:
        path = _changed_links(path, joints, true_robot.changes(truth, len(joints)), tmpdir)
    start = q0 if q0 is not None else (sc.q0 if sc is not None else np.zeros(len(joints)))
    q0 = validation.vector('q0', start, len(joints))
    if tip is None and sc is not None:
        tip = sc.tip or ('tip' if closed_form else None)   # urdf_gen names the closed forms' end link 'tip'
    task_axes = model.task_axes if closed_form else ('x', 'y', 'z')
    wall = _surface(sc, surface)
    if wall is not None and tip is None:
        raise ArgumentError('surface', 'needs a tip link (tip=...)')
    if wall is not None and not closed_form:
        path = surfaces.probe_urdf(path, tip, tmpdir)
    if payload is not None:
        path = _with_payload(path, tip, payload, tmpdir)
    spring = (model.k, model.b) if closed_form and sc.model == 'mass_spring_cubic' else None
    damping = validation.scalar('surface_damping', surface_damping, nonnegative=True)
    return WorldSpec(path, joints, q0, gravity, tip, closed_form, task_axes, wall, damping, spring, warnings)


def whole_ns(dt):
    """The physics step dt (s) as whole nanoseconds; ArgumentError naming dt otherwise."""
    dt = validation.scalar('dt', dt, positive=True)
    dt_ns = round(dt * 1e9)
    if dt_ns < 1 or abs(dt_ns - dt * 1e9) > 1e-6 * dt * 1e9:
        raise ArgumentError('dt', f'expected a whole number of nanoseconds, got {dt} s')
    return dt_ns


def clip_torque(tau, n, limit, limit_min):
    """The torque a World holds for `tau` (n,), N m or N: checked (ArgumentError naming tau) and clipped to
    +-limit (n,) (limit_min its least entry), a list of n floats. A list of n finite numbers is checked by one
    sum (validation.float_list), and most commands, inside +-limit_min, are not clipped: no numpy."""
    values = validation.float_list(tau, n)
    if values is None:
        values = validation.vector('tau', tau, n).tolist()
    if max(values) > limit_min or min(values) < -limit_min:
        values = np.minimum(np.maximum(values, -limit), limit).tolist()
    return values


def check_travel(joints, q0, travel):
    """q0 inside the URDF position limits `travel` ((lower, upper) per joint; PyBullet enforces them
    where lower <= upper), or ArgumentError naming q0."""
    for name, q, (lower, upper) in zip(joints, q0, travel):
        if lower <= upper and not lower <= q <= upper:
            raise ArgumentError('q0', f'{name} = {q} is outside the URDF limits [{lower}, {upper}]')


def _floats(element, attribute, default):
    text = element.get(attribute) if element is not None else None
    return np.array([float(v) for v in text.split()]) if text else np.array(default, dtype=float)


def in_link_axes(rotation, inertia):
    """R I R^T: inertia (3, 3) about the com in the inertial frame's axes, in the link's axes (R: (3, 3))."""
    return rotation @ inertia @ rotation.T


def urdf_inertials(xml):
    """{link: (mass kg, com (3,) m, inertia (3, 3) kg m^2 about the com in link axes)} of URDF text
    `xml` (numbers checked by robot_control.urdf.checks.check); a link without <inertial>: zeros."""
    out = {}
    for link in ET.fromstring(xml.lstrip()).findall('link'):
        inertial = link.find('inertial')
        if inertial is None:
            out[link.get('name')] = (0.0, np.zeros(3), np.zeros((3, 3)))
            continue
        origin, inertia = inertial.find('origin'), inertial.find('inertia')
        rotation = pin.rpy.rpyToMatrix(*_floats(origin, 'rpy', (0.0, 0.0, 0.0)))
        xx, xy, xz, yy, yz, zz = (_floats(inertia, k, (0.0,))[0] for k in ('ixx', 'ixy', 'ixz', 'iyy', 'iyz', 'izz'))
        tensor = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        out[link.get('name')] = (float(_floats(inertial.find('mass'), 'value', (0.0,))[0]),
                                 _floats(origin, 'xyz', (0.0, 0.0, 0.0)), in_link_axes(rotation, tensor))
    return out
