"""URDFs of the lecture's closed-form robots, whose rigid-body dynamics equal the closed forms.

urdf_xml(model_name, **params) -> URDF text. The parameters are those of the closed-form class
(robot_control.models.closed_form), with the same defaults; `gravity` (and the mass-spring's
`b`, `k`) are accepted and ignored: gravity belongs to the world, spring and friction are
applied by the simulator.

Conventions (shared by the PyBullet world and UrdfModel):
- world frame: z up, gravity along -z. Every robot has a fixed base link `base_link` at the
  world origin and an end link `tip` that carries the end-effector point mass (so that
  `tip`'s frame origin is the closed form's fk point and its link frame is its inertial frame).
- vertical-plane robots (single_link, polar_two_link, planar_two_link) move in the world x-z
  plane: the lecture's horizontal x is world +x, its vertical y is world +z. Revolute axes are
  world -y, so th = 0 is horizontal and th > 0 raises the mass.
- point masses: mass at the link origin (or inertial origin), rotational inertia exactly 0.
  Intermediate links are exactly massless (<mass value="0"/>, zero inertia, written out
  explicitly: Bullet gives links without <inertial> 1 kg). Pinocchio and PyBullet both accept
  this, so no regularizing masses are needed; the dynamics equal the closed forms to rounding.
- only `tip` has a collision shape: a sphere of radius TIP_RADIUS centred on the mass. (Bullet
  puts zero-mass links in the static collision group, so the contact link must have mass.)
- joint names equal the scenario's joint names; <dynamics damping="0" friction="0"/>.

Run `python -m robot_control.models.urdf_gen` to regenerate the shipped files
robot_control/urdf/<model_name>.urdf from the scenarios' default parameters.
"""
import argparse
import math
import os

from robot_control.validation import ArgumentError
from robot_control import urdf as urdf_files
from robot_control.models.closed_form import CLOSED_FORM

#: radius of the collision (and visual) sphere around the tip mass, m
TIP_RADIUS = 0.01
#: <limit effort>: N for prismatic joints, N m for revolute joints
EFFORT_LIMIT = 200.0
#: <limit velocity>: m/s or rad/s
VELOCITY_LIMIT = 10.0
#: revolute position limits, rad (generous: two full turns of travel)
REVOLUTE_LIMITS = (-2.0 * math.pi, 2.0 * math.pi)
#: polar robot's radius r limits, m
POLAR_R_LIMITS = (0.1, 1.2)
#: gantry and slider travel, m
PRISMATIC_LIMITS = (-1.0, 1.0)

#: the lecture's vertical-plane rotation axis: world -y (th > 0 raises a mass at +x towards +z)
PLANE_AXIS = (0.0, -1.0, 0.0)
X_AXIS, Y_AXIS, Z_AXIS = (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)

SHIPPED_DIR = urdf_files.DIR

_ROD_RADIUS = 0.01
_MATERIALS = (('grey', '0.6 0.6 0.6 1'), ('blue', '0.2 0.4 0.8 1'), ('orange', '1.0 0.5 0.1 1'))


def _num(x):
    """Shortest text that parses back to the same float (exact round trip)."""
    x = float(x) + 0.0   # + 0.0: no "-0"
    return str(int(x)) if x.is_integer() and abs(x) < 1e15 else repr(x)


def _vec(v):
    return ' '.join(_num(x) for x in v)


def _inertial(mass, com=(0.0, 0.0, 0.0)):
    return (f'    <inertial>\n'
            f'      <origin xyz="{_vec(com)}" rpy="0 0 0"/>\n'
            f'      <mass value="{_num(mass)}"/>\n'
            f'      <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/>\n'
            f'    </inertial>\n')


def _rod_visual(length, axis):
    """A thin cylinder from the link origin along +axis (x, y or z), for the GUI only."""
    rpy = {X_AXIS: (0.0, math.pi / 2, 0.0), Y_AXIS: (-math.pi / 2, 0.0, 0.0), Z_AXIS: (0.0, 0.0, 0.0)}[axis]
    centre = tuple(0.5 * length * a for a in axis)
    return (f'    <visual>\n'
            f'      <origin xyz="{_vec(centre)}" rpy="{_vec(rpy)}"/>\n'
            f'      <geometry><cylinder radius="{_num(_ROD_RADIUS)}" length="{_num(length)}"/></geometry>\n'
            f'      <material name="grey"/>\n'
            f'    </visual>\n')


def _box_visual(size, material='blue'):
    return (f'    <visual>\n'
            f'      <origin xyz="0 0 0" rpy="0 0 0"/>\n'
            f'      <geometry><box size="{_vec(size)}"/></geometry>\n'
            f'      <material name="{material}"/>\n'
            f'    </visual>\n')


def _sphere(tag, radius, com=(0.0, 0.0, 0.0), material='orange'):
    mat = f'      <material name="{material}"/>\n' if tag == 'visual' else ''
    return (f'    <{tag}>\n'
            f'      <origin xyz="{_vec(com)}" rpy="0 0 0"/>\n'
            f'      <geometry><sphere radius="{_num(radius)}"/></geometry>\n'
            f'{mat}'
            f'    </{tag}>\n')


def _link(name, mass=0.0, com=(0.0, 0.0, 0.0), shapes=''):
    return f'  <link name="{name}">\n{_inertial(mass, com)}{shapes}  </link>\n'


def _tip(mass):
    """The end link: point mass `mass` at its origin, visual and collision sphere TIP_RADIUS."""
    return _link('tip', mass, shapes=_sphere('visual', TIP_RADIUS) + _sphere('collision', TIP_RADIUS))


def _joint(name, kind, parent, child, xyz=(0.0, 0.0, 0.0), axis=None, limits=None):
    text = (f'  <joint name="{name}" type="{kind}">\n'
            f'    <parent link="{parent}"/>\n'
            f'    <child link="{child}"/>\n'
            f'    <origin xyz="{_vec(xyz)}" rpy="0 0 0"/>\n')
    if kind != 'fixed':
        lower, upper = limits
        text += (f'    <axis xyz="{_vec(axis)}"/>\n'
                 f'    <limit lower="{_num(lower)}" upper="{_num(upper)}" effort="{_num(EFFORT_LIMIT)}"'
                 f' velocity="{_num(VELOCITY_LIMIT)}"/>\n'
                 f'    <dynamics damping="0" friction="0"/>\n')
    return text + '  </joint>\n'


def _base():
    return _link('base_link', shapes=_box_visual((0.06, 0.06, 0.06), 'grey'))


def _slider(model):
    """mass_spring_cubic, force_1dof: a horizontal slider, joint x along world x."""
    return [_base(), _joint('x', 'prismatic', 'base_link', 'tip', axis=X_AXIS, limits=PRISMATIC_LIMITS),
            _tip(model.m)]


def _single_link(model):
    return [_base(),
            _joint('theta', 'revolute', 'base_link', 'link', axis=PLANE_AXIS, limits=REVOLUTE_LIMITS),
            _link('link', shapes=_rod_visual(model.l, X_AXIS)),
            _joint('tip_joint', 'fixed', 'link', 'tip', xyz=(model.l, 0.0, 0.0)),
            _tip(model.m)]


def _polar(model):
    """theta1 about world -y, then r along the rotated arm: the mass sits at radius r."""
    return [_base(),
            _joint('theta1', 'revolute', 'base_link', 'arm', axis=PLANE_AXIS, limits=REVOLUTE_LIMITS),
            _link('arm', shapes=_rod_visual(POLAR_R_LIMITS[1], X_AXIS)),
            _joint('r', 'prismatic', 'arm', 'tip', axis=X_AXIS, limits=POLAR_R_LIMITS),
            _tip(model.m)]


def _planar(model):
    """Point mass m1 at the end of link1 (its inertial origin, the elbow), m2 at the tip."""
    l1, l2 = model.l1, model.l2
    return [_base(),
            _joint('theta1', 'revolute', 'base_link', 'link1', axis=PLANE_AXIS, limits=REVOLUTE_LIMITS),
            _link('link1', model.m1, (l1, 0.0, 0.0),
                  _rod_visual(l1, X_AXIS) + _sphere('visual', TIP_RADIUS, (l1, 0.0, 0.0), 'blue')),
            _joint('theta2', 'revolute', 'link1', 'link2', xyz=(l1, 0.0, 0.0), axis=PLANE_AXIS,
                   limits=REVOLUTE_LIMITS),
            _link('link2', shapes=_rod_visual(l2, X_AXIS)),
            _joint('tip_joint', 'fixed', 'link2', 'tip', xyz=(l2, 0.0, 0.0)),
            _tip(model.m2)]


def _cartesian_xy(model):
    """y (world z, vertical) carries m2 and the x stage; x (world x) carries m1: M = diag(m1, m1 + m2)."""
    return [_base(),
            _joint('y', 'prismatic', 'base_link', 'y_stage', axis=Z_AXIS, limits=PRISMATIC_LIMITS),
            _link('y_stage', model.m2, shapes=_box_visual((0.04, 0.08, 0.04))),
            _joint('x', 'prismatic', 'y_stage', 'tip', axis=X_AXIS, limits=PRISMATIC_LIMITS),
            _tip(model.m1)]


def _cartesian_xyz(model):
    """z (vertical, m3) carries x (m2), x carries y (m1): M = diag(m1 + m2, m1, m1 + m2 + m3) in [x, y, z]."""
    return [_base(),
            _joint('z', 'prismatic', 'base_link', 'z_stage', axis=Z_AXIS, limits=PRISMATIC_LIMITS),
            _link('z_stage', model.m3, shapes=_box_visual((0.08, 0.08, 0.02), 'grey')),
            _joint('x', 'prismatic', 'z_stage', 'x_stage', axis=X_AXIS, limits=PRISMATIC_LIMITS),
            _link('x_stage', model.m2, shapes=_box_visual((0.04, 0.08, 0.04))),
            _joint('y', 'prismatic', 'x_stage', 'tip', axis=Y_AXIS, limits=PRISMATIC_LIMITS),
            _tip(model.m1)]


_BUILDERS = {
    'mass_spring_cubic': _slider,
    'force_1dof': _slider,
    'single_link': _single_link,
    'polar_two_link': _polar,
    'planar_two_link': _planar,
    'cartesian_xy': _cartesian_xy,
    'cartesian_xyz': _cartesian_xyz,
}

#: closed-form model names that have a URDF
MODELS = tuple(sorted(_BUILDERS))

#: world axis (0 x, 1 y, 2 z) of each task axis of the closed form: its fk(q) equals the tip
#: position's entries WORLD_AXES[model] (the lecture's vertical y is world z)
WORLD_AXES = {
    'mass_spring_cubic': (0,),
    'force_1dof': (0,),
    'single_link': (0, 2),
    'polar_two_link': (0, 2),
    'planar_two_link': (0, 2),
    'cartesian_xy': (0, 2),
    'cartesian_xyz': (0, 1, 2),
}


def urdf_xml(model_name, **params):
    """URDF text of closed-form robot `model_name` with physical parameters `params` (SI).

    The parameters are validated by the closed-form class itself (same names and defaults).
    """
    if model_name not in _BUILDERS:
        raise ArgumentError('model_name', f'unknown closed-form model {model_name!r}; expected one of {list(MODELS)}')
    try:
        model = CLOSED_FORM[model_name](**params)
    except TypeError as exc:
        raise ArgumentError('params', f'bad parameters {sorted(params)} for {model_name!r}: {exc}') from None
    args = ''.join(f', {k}={_num(v)}' for k, v in sorted(params.items()))
    header = ('<?xml version="1.0"?>\n'
              f'<!-- Generated by robot_control.models.urdf_gen: urdf_xml({model_name!r}{args}).\n'
              '     Do not edit: regenerate with `python -m robot_control.models.urdf_gen`.\n'
              '     World z up (gravity is the world\'s, not in this file); point masses, zero inertia. -->\n'
              f'<robot name="{model_name}">\n')
    materials = ''.join(f'  <material name="{n}"><color rgba="{c}"/></material>\n' for n, c in _MATERIALS)
    return header + materials + ''.join(_BUILDERS[model_name](model)) + '</robot>\n'


def shipped_params():
    """{model_name: params} for the shipped files: the defaults of the scenario that uses each model."""
    from robot_control.scenarios import SCENARIOS
    out = {}
    for scenario in SCENARIOS.values():
        if scenario.model in _BUILDERS and scenario.model not in out:
            out[scenario.model] = dict(scenario.params)
    for name in MODELS:
        out.setdefault(name, {})
    return out


def write_urdf(path, model_name, **params):
    """Write urdf_xml(model_name, **params) to `path` (e.g. for a simulator with other parameters); returns path."""
    text = urdf_xml(model_name, **params)
    with open(path, 'w', encoding='utf-8') as f:
        f.write(text)
    return path


def main(argv=None):
    parser = argparse.ArgumentParser(description='Regenerate the shipped URDFs of the closed-form robots.')
    parser.add_argument('--out', default=SHIPPED_DIR, help='output directory (default: the package\'s urdf/)')
    args = parser.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    for name, params in sorted(shipped_params().items()):
        print(write_urdf(os.path.join(args.out, f'{name}.urdf'), name, **params))


if __name__ == '__main__':
    main()
