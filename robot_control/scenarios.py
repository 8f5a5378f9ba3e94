"""The lecture's systems as scenarios: model, physical parameters, start, surface.

A scenario is data shared by the simulator (the "real robot") and the controller's default
configuration. The simulator may be given other physical parameters than the controller (a
model-error payload); both start from these defaults.
"""
from dataclasses import dataclass, field
from robot_control.validation import ArgumentError


@dataclass(frozen=True)
class Surface:
    """A flat elastic surface normal to task axis `axis`: f = k_e (x_N - x_e) when x_N > x_e.

    For closed-form robots `axis` indexes the model's task space (the lecture's X); `sign`
    is +1 when the robot presses by moving in +axis direction, -1 when in -axis direction.
    """

    axis: int
    x_e: float       # m, the surface's static location along the axis
    k_e: float       # N/m, environment stiffness
    sign: float = 1.0


@dataclass(frozen=True)
class Scenario:
    name: str
    model: str                    # closed-form model name (robot_control.models) or 'urdf'
    params: dict                  # the model's physical parameters, SI
    joints: tuple                 # joint names, controller and simulator order
    q0: tuple                     # initial joint positions, rad or m
    urdf: str = ''                # URDF file: shipped (robot_control/urdf) or pybullet_data relative
    tip: str = ''                 # task frame for URDF robots
    surface: Surface = None
    force_axes: tuple = ()        # task axes that are force controlled (hybrid/force scenarios)
    extra: dict = field(default_factory=dict)


IIWA_JOINTS = tuple(f'lbr_iiwa_joint_{i}' for i in range(1, 8))

SCENARIOS = {s.name: s for s in (
    Scenario('mass_spring_cubic', 'mass_spring_cubic', {'m': 1.0, 'b': 0.5, 'k': 100.0},
             ('x',), (0.0,)),
    Scenario('single_link', 'single_link', {'m': 1.0, 'l': 0.5, 'gravity': 9.81},
             ('theta',), (0.0,)),
    Scenario('polar_two_link', 'polar_two_link', {'m': 2.0, 'gravity': 9.8},
             ('theta1', 'r'), (0.0, 0.5)),
    Scenario('planar_two_link', 'planar_two_link',
             {'m1': 1.0, 'm2': 1.0, 'l1': 0.5, 'l2': 0.5, 'gravity': 9.81},
             ('theta1', 'theta2'), (0.0, 0.5)),
    Scenario('force_1dof', 'force_1dof', {'m': 1.0},
             ('x',), (0.09,), surface=Surface(axis=0, x_e=0.1, k_e=1000.0), force_axes=(0,)),
    Scenario('hybrid_cartesian_xy', 'cartesian_xy', {'m1': 1.0, 'm2': 1.0, 'gravity': 9.81},
             ('x', 'y'), (0.29, 0.0), surface=Surface(axis=0, x_e=0.3, k_e=1000.0),
             force_axes=(0,)),
    Scenario('hybrid_cartesian_xyz', 'cartesian_xyz',
             {'m1': 1.0, 'm2': 1.0, 'm3': 1.0, 'gravity': 9.81},
             ('x', 'y', 'z'), (0.0, 0.29, 0.0), surface=Surface(axis=1, x_e=0.3, k_e=1000.0),
             force_axes=(1,)),
    Scenario('iiwa', 'urdf', {}, IIWA_JOINTS, (0.0, 0.5, 0.0, -1.2, 0.0, 1.0, 0.0),
             urdf='kuka_iiwa/model.urdf', tip='lbr_iiwa_link_7',
             surface=Surface(axis=2, x_e=0.25, k_e=20000.0, sign=-1.0), force_axes=(2,)),
)}


def get(name):
    """The scenario called `name`, or ValueError listing the known ones."""
    try:
        return SCENARIOS[name]
    except KeyError:
        raise ArgumentError('scenario', f'unknown {name!r}; expected one of {sorted(SCENARIOS)}') from None
