"""The controller's parameter values -> ControllerConfig, without rclpy (robot_control.ros.config_builder)."""
import numpy as np
import pytest

from robot_control import scenarios
from robot_control.laws import LAWS
from robot_control.models import make_model
from robot_control.ros import controller_params as params
from robot_control.ros.config_builder import ConfigBuilder
from robot_control.param_table import ParameterError
from robot_control.validation import ArgumentError


def _values(**changes):
    return params.TABLE.validate(changes)


@pytest.mark.parametrize('law', sorted(LAWS))
def test_every_law_builds_from_its_scenario_with_designed_gains(law):
    """Each registered law, on a scenario it fits, gets as many motion gains as it asks for."""
    scenario = {'force': 'force_1dof', 'hybrid': 'hybrid_cartesian_xy', 'adaptive_computed_torque': 'iiwa'}.get(
        law, 'polar_two_link')
    cfg = ConfigBuilder()(_values(scenario=scenario, law=law))
    sizes = LAWS[law].servo_sizes(cfg.model, cfg.control_law.force_task.force_axes)
    gains = cfg.control_law.motion_gains
    assert (gains is None) == (not sizes) and (not sizes or gains.n == sizes[0])


def test_the_lecture_example_designs_kp_36_kv_12():
    cfg = ConfigBuilder()(_values(scenario='polar_two_link'))
    np.testing.assert_array_equal(cfg.control_law.motion_gains.kp, [36.0, 36.0])
    np.testing.assert_array_equal(cfg.control_law.motion_gains.kv, [12.0, 12.0])
    assert cfg.model.m == 2.0 and cfg.joints == ('theta1', 'r')
    assert cfg.control_law.force_task.gains is None


def test_the_model_is_kept_while_its_parameters_do_not_change():
    build = ConfigBuilder()
    first = build(_values(scenario='polar_two_link'))
    assert build(_values(scenario='polar_two_link', zeta=2.0)).model is first.model
    heavier = build(_values(scenario='polar_two_link', **{'model_params.m': 3.0}))
    assert heavier.model is not first.model and heavier.model.m == 3.0


def test_the_velocity_filter_and_integration_at_rest_reach_the_config_in_their_units():
    """velocity_filter.cutoff_hz (Hz, 0 = the message's velocities), integral_rest_velocity (rad/s, .inf = off)."""
    default = ConfigBuilder()(_values(scenario='polar_two_link'))
    assert default.velocity_cutoff_hz == 0.0 and default.integral_rest_velocity == np.inf
    cfg = ConfigBuilder()(_values(scenario='polar_two_link', integral_rest_velocity=0.01,
                                  **{'velocity_filter.cutoff_hz': 50.0}))
    assert cfg.velocity_cutoff_hz == 50.0 and cfg.integral_rest_velocity == 0.01
    for name, value in (('velocity_filter.cutoff_hz', -1.0), ('integral_rest_velocity', 0.0)):
        with pytest.raises(ParameterError) as err:
            _values(scenario='polar_two_link', **{name: value})
        assert err.value.name == name


def test_independent_joint_designs_torque_gains_from_the_inertia_at_the_scenario_start():
    cfg = ConfigBuilder()(_values(scenario='polar_two_link', law='independent_joint'))
    model = make_model('polar_two_link', m=2.0, gravity=9.8)
    diag = np.diag(model.M(np.array(scenarios.get('polar_two_link').q0)))
    np.testing.assert_allclose(cfg.control_law.motion_gains.kp, 36.0 * diag, rtol=1e-12)


def test_hybrid_gains_per_task_axis_or_per_motion_axis():
    base = dict(scenario='hybrid_cartesian_xy', law='hybrid')
    assert ConfigBuilder()(_values(**base)).control_law.motion_gains.n == 2
    cfg = ConfigBuilder()(_values(**base, kp=[50.0], kv=[10.0]))
    assert cfg.control_law.motion_gains.n == 1 and cfg.control_law.force_task.gains.n == 1


@pytest.mark.parametrize('changes, name, match', [
    ({'kp': [36.0, 36.0, 36.0]}, 'kp', 'expected 2 values'),
    ({'zeta': 0.5}, 'zeta', '0.5 breaks the rule zeta >= 1'),
    ({'q_d': [0.1]}, 'q_d', r'expected empty or 2 values \(one per joint\), got 1'),
    ({'law': 'force'}, 'law', 'force is the 1-DOF force servo'),
])
def test_errors_name_the_parameter(changes, name, match):
    with pytest.raises(ArgumentError, match=match) as err:
        ConfigBuilder()(_values(scenario='polar_two_link', **changes))
    rows, _ = params.TABLE.resolve()
    assert rows.error(err.value).name == name


def test_a_servo_gain_error_names_the_force_gain():
    """ServoGains names kv; the force servo's is force_kv (values that bypass the table's rules)."""
    values = dict(_values(scenario='hybrid_cartesian_xy', law='hybrid'), force_kv=(-1.0,))
    with pytest.raises(ParameterError, match=r'^force_kv: expected non-negative gains') as err:
        ConfigBuilder()(values)
    assert err.value.name == 'force_kv'


def test_an_invalid_robot_description_is_named_as_such():
    values = _values(model='urdf', robot_description='<robot name="r"><link name="a"/>')
    with pytest.raises(ParameterError, match='^robot_description: ') as err:
        ConfigBuilder()(values)
    assert err.value.name == 'robot_description'
    with pytest.raises(ParameterError, match='^urdf: model .urdf. needs urdf'):
        ConfigBuilder()(_values(model='urdf'))


def test_a_law_with_its_own_parameter_is_one_class_and_one_registry_entry(monkeypatch):
    """A law declares its parameter rows and its Params; once registered, its row is in the controller's
    table (checked by its rules) and its value reaches the law through the config builder."""
    import dataclasses

    from robot_control.laws import Law
    from robot_control.param_table import Row, gt

    @dataclasses.dataclass(frozen=True)
    class DampingParams:
        damping: float = 2.0

    class Damping(Law):
        """tau = g(q) - d qd, d the law's own parameter (N m s/rad)."""
        name = 'damping'
        tracks = None
        param_rows = (Row('damping', 'double', 2.0, 'damping law: viscous damping d, N m s/rad', [gt(0)]),)
        Params = DampingParams

        def torque(self, state, ref, err, int_E):
            return self.model._g(state.q) - self.config.law_params.damping * state.qd

    with pytest.raises(ParameterError, match='^law: '):
        _values(scenario='polar_two_link', law='damping')
    monkeypatch.setitem(LAWS, 'damping', Damping)
    rows, values = params.TABLE.resolve()
    assert rows['damping'].default == 2.0 and values['damping'] == 2.0
    with pytest.raises(ParameterError, match='^damping: expected a positive number'):
        _values(scenario='polar_two_link', law='damping', damping=-1.0)
    cfg = ConfigBuilder()(_values(scenario='polar_two_link', law='damping', damping=5.0))
    assert cfg.law_params == DampingParams(5.0) and cfg.control_law.name == 'damping'
    motion = ConfigBuilder()(_values(scenario='polar_two_link')).law_params.motion_servo    # computed torque's part
    assert motion.kp.tolist() == [36.0, 36.0] and motion.kv.tolist() == [12.0, 12.0]      # designed, written there


def test_a_law_declaring_the_force_setup_gets_its_rows_once_and_reads_its_values(monkeypatch):
    """The force setup (laws.force_task.ForceTask) is a part a law declares: its rows are in the law's rows and
    listed once in the table however many laws declare it; the values reach the law as its force_task, fitted
    to the model's task axes, and a law without it has no force axes whatever the parameters say."""
    from robot_control.laws import Law
    from robot_control.laws.force import ForceParams
    from robot_control.laws.force_task import PARAM_ROWS, ForceTask

    class Press(Law):
        """tau = g(q) + J^T f_d on the force axes: a feed-forward press (no servo); its Params: the force law's."""
        name, tracks, needs_task_space = 'press', 'task', True
        parts, Params = (ForceTask,), ForceParams

        def torque(self, state, ref, err, int_E):
            return self.model._g(state.q) + state.J[self.force_task.mask].T @ ref.f_d

    force_rows = [row.name for row in PARAM_ROWS]
    assert Press.uses_force and [row.name for row in Press.all_param_rows()] == force_rows
    monkeypatch.setitem(LAWS, 'press', Press)
    rows, _ = params.TABLE.resolve()
    names = rows.names()
    assert len(names) == len(set(names)) and set(force_rows) <= set(names)
    cfg = ConfigBuilder()(_values(scenario='hybrid_cartesian_xyz', law='press', force_axes=['z', 'x'],
                                  k_e=[3000.0, 1000.0], x_e=[0.5, 0.25], force_feedback='model', force_kp=[30.0, 10.0]))
    task = cfg.control_law.force_task
    assert task.force_axes == ('x', 'z') and task.force_feedback == 'model'             # in task-axis order
    np.testing.assert_array_equal(task.k_e, [1000.0, 3000.0])
    np.testing.assert_array_equal(task.x_e, [0.25, 0.5])
    np.testing.assert_array_equal(task.gains.kp, [10.0, 30.0])                           # explicit, with their axes
    np.testing.assert_array_equal(task.gains.kv, [12.0, 12.0])                           # designed (omega_n 6)
    np.testing.assert_array_equal(task.mask, [True, False, True])
    with pytest.raises(ParameterError, match=r"^k_e: expected 2 values"):
        _values(scenario='hybrid_cartesian_xyz', law='press', force_axes=['z', 'x'], k_e=[1000.0], x_e=[0.5, 0.2])
    joint = ConfigBuilder()(_values(scenario='hybrid_cartesian_xyz', law='computed_torque'))
    assert joint.control_law.force_task.force_axes == () and joint.control_law.force_task.gains is None


# -- your own arm: the task space by the arm, refusals naming the parameter ------------------------------------
XARM = dict(model='urdf', urdf='xarm_description/urdf/xarm7.urdf', tip='link7',
            joints=[f'joint{i}' for i in range(1, 8)])
SO100 = dict(model='urdf', urdf='so_arm_description/urdf/so100.urdf', tip='gripper',
             joints=['shoulder_pan', 'shoulder_lift', 'elbow_flex', 'wrist_flex', 'wrist_roll'])


def test_the_default_task_space_is_the_pose_where_the_arm_can_hold_one_and_explicit_values_stay():
    build = ConfigBuilder()
    assert params.TABLE.resolve()[0]['task_space'].default == 'auto'
    assert build(_values(**XARM, law='impedance')).model.task_axes == ('x', 'y', 'z', 'rx', 'ry', 'rz')
    assert build(_values(**SO100, law='impedance')).model.task_axes == ('x', 'y', 'z')
    # all six movable joints: the gripper's moves the jaw, not the tip; five cannot hold a pose
    every = build(_values(**dict(SO100, joints=[]), law='impedance')).model
    assert len(every.joint_names) == 6 and every.task_axes == ('x', 'y', 'z')
    assert build(_values(**XARM, law='impedance', task_space='position')).model.task_axes == ('x', 'y', 'z')
    # the lecture's URDF scenarios are written in the tip's position
    assert build(_values(scenario='iiwa', law='hybrid')).model.task_axes == ('x', 'y', 'z')


@pytest.mark.parametrize('arm, changes, name, match', [
    (SO100, {'task_space': 'pose'}, 'task_space',
     r"^task_space: pose has 6 task axes: 5 of the joints \['shoulder_pan', .*\] move the tip gripper .*, too few"),
    (dict(SO100, joints=[]), {'task_space': 'pose'}, 'task_space',
     r"^task_space: pose has 6 task axes: 5 of the joints \[.*'wrist_roll', 'gripper'\] move the tip gripper "
     r"\(\['shoulder_pan', 'shoulder_lift', 'elbow_flex', 'wrist_flex', 'wrist_roll'\]\), too few to hold a pose"),
    (XARM, {'task_space': 'position', 'cartesian_stiffness': [1000.0, 1000.0, 1000.0, 100.0, 0.0, 50.0]},
     'cartesian_stiffness', r'^cartesian_stiffness: rx = 100, rz = 50 act on the orientation, which the task '
                            r"space \['x', 'y', 'z'\] does not hold: set task_space pose"),
    (SO100, {'cartesian_damping': [10.0, 10.0, 10.0, 1.0, 1.0, 1.0]}, 'cartesian_damping',
     '^cartesian_damping: rx = 1, ry = 1, rz = 1 act on the orientation'),
])
def test_a_configuration_that_cannot_work_is_refused_naming_the_parameter(arm, changes, name, match):
    with pytest.raises(ArgumentError, match=match) as err:
        ConfigBuilder()(_values(**arm, law='impedance', **changes))
    rows, _ = params.TABLE.resolve()
    assert rows.error(err.value).name == name


def test_translational_stiffness_alone_in_a_position_task_space_is_taken():
    cfg = ConfigBuilder()(_values(**SO100, law='impedance', cartesian_stiffness=[500.0, 600.0, 700.0, 0.0, 0.0, 0.0]))
    np.testing.assert_array_equal(cfg.control_law.K, [500.0, 600.0, 700.0])
    assert cfg.control_law.w_max is None                   # explicit: used as given


def test_the_control_period_is_the_impedance_law_s_and_caps_its_designed_stiffness():
    """control_period (the node parameter) reaches the impedance law's parameters: w_max = 0.1 pi / (T max(1, zeta))."""
    slow = ConfigBuilder()(_values(**SO100, law='impedance', control_period=0.002))
    assert slow.law_params.control_period == 0.002 and not hasattr(slow, 'control_period')
    assert slow.control_law.w_max == pytest.approx(0.1 * np.pi / 0.002)
    assert ConfigBuilder()(_values(**SO100, law='impedance')).control_law.w_max == pytest.approx(0.1 * np.pi / 0.001)
