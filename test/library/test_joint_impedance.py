"""Joint impedance (robot_control.laws.joint_impedance) against its equation, Pinocchio and a simulated iiwa.

tau = M(q) qdd_d + C(q, qd) qd + g(q) + K E + D Ed (+ ki int E): the model terms are rnea(q, qd, qdd_d)
(checked against pinocchio.rnea of the iiwa's URDF, built here, to 1e-9); D_i = 2 zeta sqrt(K_i M_ii(q)).

In process, the controller core against sim_bridge.world.World (PyBullet, 1 kHz, the iiwa from its
scenario's start):
  - a 0.5 rad quintic move of all 7 joints in 2 s, K = 100 N m/rad: RMS tracking error 1e-6 to 6e-5 rad
    per joint (measured), checked < 5e-4 rad;
  - 0.5 N m unmodelled on joints 5-7 (the wrist): the steady error is -d / K = -5.000e-3 rad (measured to
    1e-8), checked to 5e-5 rad. Computed torque (kp = 36 1/s^2) comes to rest at E = -M(q)^-1 d / kp, on
    the diagonal d / (M_ii kp), M_ii kp = 0.49, 0.32, 0.036 N m/rad on the wrist at the scenario's start:
    under 0.5 N m its wrist goes -1.28, -0.59, -2.55 rad off (joint 7 to its limit), checked > 0.5 rad;
    under 0.01 N m it rests at -0.0214, -0.0340, -0.276 rad, -M(q)^-1 d / kp to 1e-6 (checked at 2 %).
"""
import numpy as np
import pinocchio as pin
import pybullet_data
import pytest

from robot_control import scenarios
from robot_control.laws.servo import gain_params
from robot_control.core.config import ControllerConfig
from robot_control.core.tick import ControllerCore
from robot_control.gains import design
from robot_control.laws import State, Reference, joint_impedance
from robot_control.laws.joint_impedance import JointImpedanceParams, _designed_damping
from robot_control.models import for_scenario, make_model
from robot_control.param_table import ParameterError
from robot_control.ros import controller_params as params
from robot_control.ros.config_builder import ConfigBuilder
from robot_control.validation import ArgumentError
from sim_bridge.world import World

DT = 0.001
K = 100.0
WRIST = np.array([0.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.5])    # N m, on joints 5-7
RNG = np.random.default_rng(20261126)


@pytest.fixture(scope='module')
def iiwa():
    return for_scenario('iiwa')


def _state(n, scale=0.5):
    return [RNG.uniform(-scale, scale, n) for _ in range(6)]


def test_the_law_is_its_equation_by_hand():
    """polar_two_link: M qdd_d + C qd + g + K E + D Ed + ki int E from the model's M, C, g, term by term;
    the designed damping is 2 zeta sqrt(K_i M_ii(q))."""
    model = make_model('polar_two_link', m=2.0, gravity=9.8)
    q, qd, q_d, qd_d, qdd_d, int_E = _state(2)
    q = q + np.array([0.0, 1.0])        # r > 0
    K, D, ki = np.array([40.0, 90.0]), np.array([3.0, 5.0]), np.array([7.0, 11.0])
    by_hand = model.M(q) @ qdd_d + model.C(q, qd) @ qd + model.g(q) + K * (q_d - q) + D * (qd_d - qd) + ki * int_E
    np.testing.assert_allclose(joint_impedance(model, q, qd, q_d, qd_d, qdd_d, K, D, ki=ki, int_E=int_E), by_hand,
                               rtol=1e-12, atol=1e-12)
    designed = 2 * 0.7 * np.sqrt(K * np.diag(model.M(q)))
    np.testing.assert_allclose(joint_impedance(model, q, qd, q_d, qd_d, qdd_d, K, damping_ratio=0.7),
                               joint_impedance(model, q, qd, q_d, qd_d, qdd_d, K, designed), rtol=1e-12, atol=1e-12)
    no_integral = joint_impedance(model, q, qd, q_d, qd_d, qdd_d, K, D, ki=ki)
    np.testing.assert_allclose(no_integral, by_hand - ki * int_E, rtol=1e-12, atol=1e-12)


def test_the_model_terms_are_pinocchio_rnea_on_the_iiwa(iiwa):
    """K (q_d - q) + D (qd_d - qd) + rnea(q, qd, qdd_d), with rnea from Pinocchio's own model of the URDF."""
    pin_model = pin.buildModelFromUrdf(f'{pybullet_data.getDataPath()}/{scenarios.get("iiwa").urdf}')
    pin_model.gravity.linear = np.array([0.0, 0.0, -9.81])
    data = pin_model.createData()
    K, D = np.linspace(50.0, 500.0, 7), np.linspace(1.0, 20.0, 7)
    for _ in range(5):
        q, qd, q_d, qd_d, qdd_d, _ = _state(7, 1.0)
        expected = pin.rnea(pin_model, data, q, qd, qdd_d) + K * (q_d - q) + D * (qd_d - qd)
        np.testing.assert_allclose(joint_impedance(iiwa, q, qd, q_d, qd_d, qdd_d, K, D), expected, rtol=1e-9,
                                   atol=1e-9)


@pytest.mark.parametrize('kwargs, name', [
    ({'K': [100.0] * 6}, 'K'), ({'K': -1.0}, 'K'), ({'K': [np.nan] * 7}, 'K'), ({'D': [1.0, 2.0]}, 'D'),
    ({'D': -1.0}, 'D'), ({'damping_ratio': -0.5}, 'damping_ratio'), ({'ki': [-1.0] * 7}, 'ki'),
    ({'int_E': np.zeros(6)}, 'int_E'), ({'q': np.zeros(6)}, 'q'), ({'qdd_d': [np.inf] * 7}, 'qdd_d')])
def test_argument_errors_name_the_argument(iiwa, kwargs, name):
    args = dict(q=np.zeros(7), qd=np.zeros(7), q_d=np.zeros(7), qd_d=np.zeros(7), qdd_d=np.zeros(7), K=K)
    with pytest.raises(ArgumentError) as err:
        joint_impedance(iiwa, **{**args, **kwargs})
    assert err.value.name == name


def test_the_law_s_parameters_are_checked_naming_them(iiwa):
    assert ControllerConfig(iiwa, law='joint_impedance').law_params == JointImpedanceParams((100.0,), 1.0, (), ())
    for law_params, match in (({'joint_stiffness': ()}, '^joint_stiffness: expected one value'),
                              ({'joint_stiffness': [100.0] * 3}, '^joint_stiffness: expected length 7'),
                              ({'joint_damping': [-1.0]}, '^joint_damping: expected one value'),
                              ({'joint_damping_ratio': -1.0}, '^joint_damping_ratio:'),
                              ({'joint_ki': [1.0, 2.0]}, '^joint_ki: expected length 7'),
                              ({'kp': [1.0]}, r"^law_params: \['kp'\] are not parameters of law joint_impedance")):
        with pytest.raises(ArgumentError, match=match):
            ControllerConfig(iiwa, law='joint_impedance', law_params=law_params)


def test_the_integral_map_is_diag_ki_and_the_torque_s_derivative(iiwa):
    cfg = ControllerConfig(iiwa, law='joint_impedance', integral=True,
                           law_params={'joint_stiffness': np.linspace(100, 400, 7), 'joint_ki': np.linspace(5, 35, 7)})
    law = cfg.control_law
    q, qd, q_d, qd_d, qdd_d, z = _state(7)
    state, ref = State(0.1, q, qd), Reference(q_d, qd_d, qdd_d)
    err = law.errors(state, ref)
    tau = law.torque(state, ref, err, z).copy()
    fd = np.column_stack([law.torque(state, ref, err, z + e) - tau for e in np.eye(7)])
    np.testing.assert_allclose(law.integral_map(state, ref, err), fd, rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(law.integral_map(state, ref, err), np.diag(np.linspace(5, 35, 7)))
    ki, D = law.integral_gains()
    np.testing.assert_allclose(D, _designed_damping(law.K, np.diag(iiwa.M(q)), 1.0), rtol=1e-12)
    default = ControllerConfig(iiwa, law='joint_impedance', integral=True).control_law
    np.testing.assert_array_equal(default.integral_gains()[0], np.full(7, K))      # K / 1 s


def run_iiwa(config, T=3.0, disturbance=None):
    """The controller core on the simulated iiwa for T s from the scenario's start, a 0.5 rad quintic move of
    every joint in 2 s: (errors E per tick (k, 7), the last measured q). disturbance(q, qd) -> joint torque
    (7,) applied by the World over the next control period, or None."""
    with World('iiwa', dt=DT) as world:
        q0 = world.state()[0]
        core = ControllerCore(config)
        core.set_goal(q0 + 0.5, 2.0)
        errors = []
        for k in range(int(round(T / DT))):
            q, qd, _ = world.state()
            if disturbance is not None:
                world.set_disturbance(joint_torque=disturbance(q, qd))
            world.set_torque(core.update(k * DT, q, qd))
            errors.append(core.error[0].copy())
            world.step(1)
        return np.array(errors), world.state()[0]


def test_a_half_radian_move_of_every_joint_is_tracked(iiwa):
    errors, q = run_iiwa(ControllerConfig(iiwa, law='joint_impedance'))
    rms = np.sqrt((errors ** 2).mean(axis=0))
    assert rms.max() < 5e-4, rms
    assert np.abs(errors[-1]).max() < 1e-4, errors[-1]


def test_an_unmodelled_wrist_torque_leaves_d_over_k_where_computed_torque_leaves_d_over_m_kp(iiwa):
    """0.5 N m on joints 5-7: joint impedance comes to rest at E = -d / K (K = 100 N m/rad: 5 mrad).
    Computed torque (kp = 36 1/s^2) comes to rest at E = -M(q)^-1 d / kp (its stiffness on the wrist's
    diagonal M_ii kp < 0.6 N m/rad): under 0.5 N m the wrist goes more than 0.5 rad off its reference
    (joint 7 to its limit), under 0.01 N m it rests where that equation says."""
    constant = lambda q, qd: WRIST  # noqa: E731
    errors, _ = run_iiwa(ControllerConfig(iiwa, law='joint_impedance'), disturbance=constant)
    np.testing.assert_allclose(errors[-1], -WRIST / K, rtol=0, atol=5e-5)
    kp, wrist = 36.0, slice(4, 7)
    computed_torque = ControllerConfig(iiwa, law_params=gain_params(design(1.0, 12.0).gains(7)))
    ct, _ = run_iiwa(computed_torque, disturbance=constant)
    assert (np.abs(ct[-1][wrist]) > 0.5).all(), ct[-1]
    small = WRIST / 50
    ct, q = run_iiwa(computed_torque, T=4.0, disturbance=lambda q, qd: small)
    np.testing.assert_allclose(ct[-1], -np.linalg.solve(iiwa.M(q), small) / kp, rtol=0.02, atol=1e-4)
    stiffness = np.diag(iiwa.M(np.array(scenarios.get('iiwa').q0)))[wrist] * kp
    assert (stiffness < 0.6).all(), stiffness          # N m/rad, against joint impedance's 100


def test_the_law_s_rows_are_in_the_controller_table_and_reach_the_law_through_the_config_builder():
    rows, values = params.TABLE.resolve()
    assert rows['joint_stiffness'].default == (100.0,) and values['joint_damping'] == () and 'N m/rad' in \
        rows['joint_stiffness'].description
    cfg = ConfigBuilder()(params.TABLE.validate({'scenario': 'iiwa', 'law': 'joint_impedance', 'integral': True,
                                                  'joint_stiffness': [300.0] * 4 + [50.0] * 3, 'joint_damping': [5.0]}))
    law = cfg.control_law
    assert cfg.control_law.motion_gains is None and law.name == 'joint_impedance' and cfg.integral_dim == 7
    np.testing.assert_array_equal(law.K, [300.0] * 4 + [50.0] * 3)
    np.testing.assert_array_equal(law.damping(np.zeros(7)), np.full(7, 5.0))
    np.testing.assert_array_equal(law.integral_gains()[0], law.K)
    with pytest.raises(ParameterError, match='^joint_stiffness: expected non-negative'):
        params.TABLE.validate({'law': 'joint_impedance', 'joint_stiffness': [-1.0]})
    with pytest.raises(ArgumentError) as err:
        ConfigBuilder()(params.TABLE.validate({'scenario': 'iiwa', 'law': 'joint_impedance', 'joint_ki': [1.0] * 3}))
    assert err.value.name == 'joint_ki'


def test_with_integral_action_the_wrist_error_under_a_constant_torque_dies_out(iiwa):
    """ki = K / 1 s (the default): 6 s after the move started, 4 s after it ended, the 5 mrad of PD is gone
    (measured 1.2e-5 rad; 2.5e-4 at 3 s), checked < 2 % of d / K."""
    errors, _ = run_iiwa(ControllerConfig(iiwa, law='joint_impedance', integral=True), T=6.0,
                         disturbance=lambda q, qd: WRIST)
    assert np.abs(errors[-1]).max() < 0.02 * WRIST.max() / K, errors[-1]
