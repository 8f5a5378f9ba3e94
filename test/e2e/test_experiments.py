"""The lecture's experiments end to end: sim_bridge_node and controller_node as separate
processes over DDS (loopback, a private domain per run), lockstep, references and metrics by
robot_control.tools.demo. Each run is shared by the tests that read it (module-scoped `runs`); all runs
are submitted when the module starts and execute two at a time.

Figures checked (the issue's):
1. polar example, step from rest: the joint error follows e0 (1 + 6 t) exp(-6 t) within 2 % of e0.
2. planar_two_link, fast path: computed torque RMS error >= 10x lower than independent-joint PD of
   the same design.
3. constant disturbance d: PD steady-state error = d / (m kp) within 5 %; PID below 1 % of that.
4. model error (robot 20 % heavier than the controller's model): PD leaves an error, PID removes it.
5. force_1dof: the force step follows the designed dynamics; steady-state force error < 1 %.
6. hybrid_cartesian_xy: 10 N on the wall, force RMS error < 2 % after settling, y RMS error < 1 mm.
7. URDF arms (the iiwa, the Franka Panda with its fingers held, the 6-DOF UR5 of example-robot-data):
   joint-space point-to-point ends within 1e-3 rad without saturating; hybrid on the table (iiwa, Panda):
   10 N with force error < 5 % while drawing a 10 cm line with path error < 2 mm.
8. mass_spring_cubic tracks a sine with the partitioned law.
9. Beyond the lecture, on the iiwa: Cartesian impedance (K = 1000 N/m, 100 N m/rad) under a 10 N push along
   -z set on the bridge at run time deflects the tip 10 mm within 5 %, the other axes < 0.5 mm, the
   orientation < 5 mrad, and it returns without overshoot beyond 2 %; the impedance law tracks a 10 cm
   circle with a 20 degree wrist rotation within 2 mm and 10 mrad RMS; gravity compensation holding 2 kg on
   the tip drifts < 1 mrad over 3 s with the payload configured and sags without it; hybrid control in the
   pose task space presses 10 N on the table while drawing a line with the tool vertical (< 10 mrad).
Repeated runs give identical numbers; the recorded bag of one run is checked with rosbags.
"""
import math

import numpy as np
import pytest

from support.e2e import Runs, common_ticks, physics_summary, restrict
from robot_control.tools import demo_experiments as exps
from robot_control import scenarios
from robot_control.tools.demo_metrics import critically_damped

OMEGA = 6.0          # rad/s: every config designs zeta = 1, omega_n = 0.5 * 12 rad/s

#: key -> (experiment, keyword arguments of the run)
RUNS = {
    'polar': ('polar_step', dict(duration=1.7, record=True)),
    'polar_again': ('polar_step', dict(duration=1.7)),
    'planar_ct': ('planar_fast_path', dict(duration=2.5)),
    'planar_ij': ('planar_independent_joint', dict(duration=2.5)),
    'dist_pd': ('disturbance_pd', dict(duration=2.0)),
    'dist_pid': ('disturbance_pid', dict(duration=2.0)),
    'model_pd': ('model_error_pd', dict(duration=2.5)),
    'model_pid': ('model_error_pid', dict(duration=2.5)),
    'force': ('force_steps', dict(duration=2.3)),          # the 0 -> 10 N step, and 10 -> 5 N at 2.0 s
    'force_again': ('force_steps', dict(duration=2.3)),
    'hybrid_xy': ('hybrid_xy_wall', dict(duration=4.0)),
    'iiwa_ptp': ('iiwa_ptp', dict(duration=2.7)),
    'iiwa_line': ('iiwa_hybrid_line', dict(duration=3.5)),
    'panda_ptp': ('panda_ptp', dict(duration=2.7)),
    'panda_line': ('panda_hybrid_line', dict(duration=3.5)),
    'ur5_ptp': ('ur5_ptp', dict(duration=2.7)),
    'sine': ('mass_spring_sine', dict(duration=2.5)),
    'push': ('impedance_push', dict(duration=3.5)),
    'pose': ('pose_tracking', dict(duration=3.8)),
    'payload_known': ('payload_compensated', dict(duration=3.0)),
    'payload_bare': ('payload_unmodelled', dict(duration=3.0)),
    'iiwa_vertical': ('iiwa_hybrid_vertical', dict(duration=3.5)),
}


@pytest.fixture(scope='module')
def runs(tmp_path_factory):
    r = Runs(tmp_path_factory.mktemp('experiments'))
    try:
        for key, (name, kwargs) in RUNS.items():
            r.submit(key, name, **kwargs)
        yield r
    finally:
        r.close()


#: smallest share of the control ticks the collector must see. An observer starved of CPU misses
#: samples; the writers keep 10000 (qos.PUBLISHER_DEPTH) and DDS re-sends them after the next
#: heartbeat, which the demo waits for (demo.REPAIR_TIMEOUT): measured, 18 of 18 runs complete with
#: three runs in one process and two busy loops on two cores. 2 % margin for the unforeseen.
MIN_TICKS = 0.98


def _complete(result):
    """True when every tick of the run was collected; fails when too many were lost."""
    s = result.summary
    assert s['samples'] >= MIN_TICKS * s['expected_ticks'], f'too many ticks lost: {s["lost_messages"]}'
    # the demo starts the run once every stream of the tick has delivered a sample: the first tick is never lost
    first = {topic: lost['ranges_s'][0] for topic, lost in s['lost_messages'].items()
             if lost['ranges_s'] and lost['ranges_s'][0][0] == 0.0}
    assert not first, f'the first tick did not reach the collector: {first}'
    if s['samples'] < s['expected_ticks']:
        print(f'warning: {s["experiment"]}: {s["expected_ticks"] - s["samples"]} of {s["expected_ticks"]} ticks '
              'lost on the way to the collector')
    return s['samples'] == s['expected_ticks']


# -- 1. the lecture's worked example -----------------------------------------------------------------
def test_polar_step_follows_the_critically_damped_solution(runs):
    result = runs.get('polar')
    d = result.data
    _complete(result)
    spec = exps.get('polar_step').trajectory
    goal = np.array(spec.positions[0])
    q0 = np.array(scenarios.get('polar_two_link').q0)
    t_step = spec.t_start + spec.times[0]             # the goal is reached one control period after 0.5 s
    k0 = int(np.searchsorted(d.t, t_step - 1e-9))
    assert np.all(np.abs(d.ref_pos[k0:] - goal) < 1e-12) and np.all(np.abs(d.ref_pos[:k0] - q0) < 1e-12)
    e0 = goal - q0                                    # from rest at q0
    assert abs(d.t[k0] - t_step) > 1e-9 or np.allclose(d.err_pos[k0], e0, atol=1e-12)
    tau = d.t[k0:] - t_step
    predicted = critically_damped(tau[:, None], e0[None, :], OMEGA)
    deviation = np.max(np.abs(d.err_pos[k0:] - predicted), axis=0) / np.abs(e0)
    print(f'polar step: max |e - e_analytic| / e0 = {deviation.tolist()} over {tau[-1]:.3f} s')
    assert np.all(deviation < 0.02)
    assert np.all(np.abs(d.err_pos[-1]) < 0.02 * np.abs(e0))   # settled: 2 % settling time is 0.97 s


# -- 2. computed torque vs independent joint ----------------------------------------------------------
def test_planar_computed_torque_beats_independent_joint_pd_by_10x(runs):
    ct, ij = runs.get('planar_ct'), runs.get('planar_ij')
    _complete(ct), _complete(ij)
    rms_ct = np.array(list(ct.summary['rms_error'].values()))
    rms_ij = np.array(list(ij.summary['rms_error'].values()))
    ratio = rms_ij / rms_ct
    print(f'planar fast path: RMS error CT {rms_ct.tolist()} rad, independent joint {rms_ij.tolist()} rad, '
          f'ratio {ratio.tolist()}')
    assert np.all(ratio >= 10.0)
    assert np.linalg.norm(rms_ij) / np.linalg.norm(rms_ct) >= 10.0
    assert ct.summary['saturated_ticks'] == 0 and ij.summary['saturated_ticks'] == 0


# -- 3. disturbance rejection -------------------------------------------------------------------------
def _pd_steady_state_prediction():
    sc = scenarios.get('mass_spring_cubic')
    kp = OMEGA ** 2
    return exps.D_DISTURBANCE / (sc.params['m'] * kp)


def test_pd_steady_state_error_is_d_over_m_kp(runs):
    result = runs.get('dist_pd')
    _complete(result)
    e_ss = result.summary['steady_state_error']['x']
    predicted = _pd_steady_state_prediction()
    print(f'disturbance d = {exps.D_DISTURBANCE} N, PD: e_ss = {e_ss:.6g} m, d/(m kp) = {predicted:.6g} m, '
          f'ratio {e_ss / predicted:.5f}')
    assert abs(e_ss - predicted) <= 0.05 * predicted


def test_pid_removes_the_disturbance_error(runs):
    result = runs.get('dist_pid')
    _complete(result)
    e_ss = result.summary['steady_state_error']['x']
    predicted = _pd_steady_state_prediction()
    print(f'disturbance d = {exps.D_DISTURBANCE} N, PID: e_ss = {e_ss:.3g} m = {abs(e_ss) / predicted:.2e} d/(m kp)')
    assert abs(e_ss) < 0.01 * predicted


# -- 4. model error -----------------------------------------------------------------------------------
def _model_error_prediction():
    """PD computed torque with the model's m_hat, robot m at rest: m_hat r^2 kp e1 = (m - m_hat) g r cos(th1),
    m_hat kp e2 = (m - m_hat) g sin(th1), th1 = th1_d - e1, r = r_d - e2 (fixed point)."""
    sc = scenarios.get('polar_two_link')
    m_hat, g = sc.params['m'], sc.params['gravity']
    dm = m_hat * (exps.MODEL_ERROR - 1.0)
    kp = OMEGA ** 2
    th_d, r_d = exps.get('model_error_pd').bridge['initial_positions']
    e1 = e2 = 0.0
    for _ in range(200):
        th, r = th_d - e1, r_d - e2
        e1, e2 = dm * g * math.cos(th) / (m_hat * r * kp), dm * g * math.sin(th) / (m_hat * kp)
    return np.array([e1, e2])


def test_model_error_pd_leaves_the_predicted_error(runs):
    result = runs.get('model_pd')
    _complete(result)
    e_ss = np.array(list(result.summary['steady_state_error'].values()))
    predicted = _model_error_prediction()
    print(f'model error 20 %, PD: e_ss = {e_ss.tolist()} (rad, m), predicted {predicted.tolist()}')
    assert np.all(np.abs(e_ss - predicted) <= 0.05 * np.abs(predicted))


def test_model_error_pid_removes_it(runs):
    pd, pid = runs.get('model_pd'), runs.get('model_pid')
    _complete(pid)
    e_pd = np.abs(list(pd.summary['steady_state_error'].values()))
    e_pid = np.abs(list(pid.summary['steady_state_error'].values()))
    print(f'model error 20 %: |e_ss| PD {e_pd.tolist()}, PID {e_pid.tolist()} (rad, m)')
    assert np.all(e_pid < 0.01 * e_pd)


# -- 5. force control ---------------------------------------------------------------------------------
def test_force_step_follows_the_designed_dynamics(runs):
    """The force error of a 0 -> f_d step from contact at rest follows e_f'' + 12 e_f' + 36 e_f = 0.

    config/force_1dof.yaml sets force_lead_time = the 1 ms control period: the law uses f + fdot dt, the
    force at the end of the command's hold, which PyBullet's stiff contact applies (with the lecture's
    beta = f on the sampled force the response lags the design by 3.5 % of f_d and settles 14 % late).
    Checked: the deviation from the analytic response (< 1 % of f_d; measured 0.16 %), the 2 % settling
    time against the design's 0.972 s (within 3 %; measured 0.978 s), no overshoot, and the steady-state
    error (< 1 %, the issue's figure).
    """
    result = runs.get('force')
    d, s = result.data, result.summary
    _complete(result)
    exp = exps.get('force_steps')
    f_d = exp.force[0]
    t_next, (f_next,) = exp.force_events[0]
    first = d.t < t_next - 1e-9                              # the first step, up to the next one at 2.0 s
    f = d.force_measured()[first, 0]
    ef = d.force_reference()[first, 0] - f
    ok = np.isfinite(ef)
    predicted = critically_damped(d.t[first], f_d, OMEGA)
    deviation = np.max(np.abs(ef[ok] - predicted[ok])) / f_d
    designed_settling = 5.8340 / OMEGA        # (1 + x) exp(-x) = 0.02 at x = 5.834
    e_ss = float(np.nanmean(ef[d.t[first] >= t_next - 0.5]))
    print(f'force step 0 -> {f_d} N: max |e_f - e_f analytic| = {deviation:.2%} of f_d; 2 % settling '
          f'{s["force_settling_time_s"]:.3f} s (designed {designed_settling:.3f} s); max f {np.nanmax(f):.4f} N; '
          f'steady-state force error {e_ss:.3g} N = {abs(e_ss) / f_d:.2e} f_d')
    assert np.all(d.force_reference()[first, 0] == f_d)      # a step at the first tick (force_ramp_time 0)
    # the next step, sent before the run starts stamped 2.0 s, is applied at exactly that tick
    assert np.all(d.force_reference()[~first, 0] == f_next) and np.isclose(d.t[~first][0], t_next)
    assert deviation < 0.01
    assert abs(s['force_settling_time_s'] - designed_settling) < 0.03 * designed_settling
    assert np.nanmax(f) < f_d * 1.01                          # critically damped: no overshoot
    assert abs(e_ss) < 0.01 * f_d


# -- 6. hybrid position/force, the lecture's example ------------------------------------------------------
def test_hybrid_xy_presses_10N_while_y_tracks_the_sine(runs):
    result = runs.get('hybrid_xy')
    s = result.summary
    _complete(result)
    f_d = exps.get('hybrid_xy_wall').force[0]
    f_rms, y_rms = s['force_rms_error']['x'], s['rms_error']['y']
    print(f'hybrid xy: force RMS error after {exps.get("hybrid_xy_wall").force_window} s = {f_rms:.3g} N '
          f'({f_rms / f_d:.2%} of f_d), y RMS error {y_rms:.3g} m')
    assert f_rms < 0.02 * f_d
    assert y_rms < 1e-3


# -- 7. URDF arms ---------------------------------------------------------------------------------------
@pytest.mark.parametrize('key', ['iiwa_ptp', 'panda_ptp', 'ur5_ptp'])
def test_arm_point_to_point_ends_within_1e_3_rad(runs, key):
    result = runs.get(key)
    d = result.data
    _complete(result)
    name = RUNS[key][0]
    goal = np.array(exps.get(name).trajectory.positions[0])
    final = np.abs(d.q[-1] - goal)
    print(f'{name}: final |q - q_goal| = {final.max():.3g} rad (max over joints), RMS tracking error '
          f'{max(result.summary["rms_error"].values()):.3g} rad, max {max(result.summary["max_error"].values()):.3g} rad, '
          f'max |tau| {np.abs(d.tau_cmd).max():.3g} N m')
    assert np.all(d.ref_pos[-1] == goal)
    assert np.all(final < 1e-3)
    assert result.summary['saturated_ticks'] == 0


@pytest.mark.parametrize('key', ['iiwa_line', 'panda_line'])
def test_arm_hybrid_presses_10N_while_drawing_a_line(runs, key):
    result = runs.get(key)
    d, s = result.data, result.summary
    _complete(result)
    exp = exps.get(RUNS[key][0])
    f_d = abs(exp.force[0])
    win = d.window(exp.force_window)
    ef = (d.force_reference() - d.force_measured())[win, 0]
    path = np.linalg.norm(d.motion_error(), axis=1)
    print(f'{exp.name}: force error after {exp.force_window} s: max {np.nanmax(np.abs(ef)):.3g} N, RMS '
          f'{s["force_rms_error"]["z"]:.3g} N (f_d {f_d} N); path error max {path.max():.3g} m, RMS '
          f'{np.sqrt(np.mean(path ** 2)):.3g} m')
    assert np.nanmax(np.abs(ef)) < 0.05 * f_d
    assert path.max() < 2e-3


# -- 8. the partitioned law on the nonlinear spring -------------------------------------------------------
def test_mass_spring_cubic_tracks_a_sine(runs):
    result = runs.get('sine')
    d, s = result.data, result.summary
    _complete(result)
    amplitude = np.ptp(d.ref_pos[:, 0])
    print(f'mass_spring_cubic sine ({amplitude:.3g} m peak to peak): RMS error {s["rms_error"]["x"]:.3g} m, '
          f'max {s["max_error"]["x"]:.3g} m')
    assert amplitude > 0.3
    assert s['rms_error']['x'] < 1e-3 * amplitude * 2.5    # < 1 mm for the 0.4 m sine
    assert s['max_error']['x'] < 2e-3


# -- 9. beyond the lecture: impedance, pose targets, a payload ---------------------------------------------
def test_impedance_push_deflects_the_tip_by_force_over_stiffness(runs):
    """Static deflection K^-1 F along the push; the other translation axes hold still in the steady state
    (while the push comes and goes they move transiently: the operational-space inertia couples them, and
    the law keeps it); no overshoot on the way back."""
    result = runs.get('push')
    s = result.summary
    _complete(result)
    exp = exps.get('impedance_push')
    fig = s['figures']
    expected = -exps.PUSH / exp.controller['cartesian_stiffness'][2]
    (on, off) = [event['t_applied'] for event in s['bridge_events']]
    print(f'impedance push {exps.PUSH} N on at {on:.3f} s, off at {off:.3f} s: deflection '
          f'{fig["push_deflection_m"] * 1e3:.4f} mm (K^-1 F = {expected * 1e3:.1f} mm), other axes '
          f'{fig["push_other_axes_m"] * 1e3:.2g} mm (peak {fig["push_other_axes_peak_m"] * 1e3:.3f} mm), rotation max '
          f'{fig["push_rotation_max_rad"] * 1e3:.3f} mrad, overshoot on return {fig["push_return_overshoot"]:.2%}')
    assert [e['t'] for e in s['bridge_events']] == [t for t, _ in exp.bridge_events]
    assert (on, off) == (0.5, 2.0)                         # the bridge paused itself there (pause_at)
    assert abs(fig['push_deflection_m'] - expected) <= 0.05 * abs(expected)
    assert fig['push_other_axes_m'] < 0.5e-3
    assert fig['push_rotation_max_rad'] < 5e-3
    assert fig['push_return_overshoot'] < 0.02
    assert max(s['final_error'].values()) < 1e-4           # back at the start pose


def test_impedance_tracks_a_circle_with_a_wrist_rotation(runs):
    import pinocchio as pin
    result = runs.get('pose')
    d, fig = result.data, result.summary['figures']
    _complete(result)
    names = list(d.ref_names)
    xyz = d.ref_pos[:, [names.index(a) for a in ('x', 'y', 'z')]]
    rot = d.ref_pos[:, [names.index(a) for a in ('rx', 'ry', 'rz')]]
    turned = max(np.linalg.norm(pin.log3(pin.exp3(r) @ pin.exp3(rot[0]).T)) for r in rot)
    print(f'pose tracking: circle {np.ptp(xyz[:, 0]) * 1e3:.1f} x {np.ptp(xyz[:, 1]) * 1e3:.1f} mm, wrist turned up to '
          f'{math.degrees(turned):.2f} degrees; RMS error {fig["position_rms_m"] * 1e3:.4f} mm, '
          f'{fig["orientation_rms_rad"] * 1e3:.4f} mrad')
    assert np.allclose(np.ptp(xyz[:, :2], axis=0), 2 * exps.IIWA_CIRCLE, rtol=1e-3)
    assert abs(turned - exps.IIWA_WRIST) < 1e-3
    assert fig['position_rms_m'] < 2e-3 and fig['orientation_rms_rad'] < 10e-3
    assert result.summary['saturated_ticks'] == 0


def test_gravity_compensation_holds_a_configured_payload_and_sags_without_it(runs):
    known, bare = runs.get('payload_known'), runs.get('payload_bare')
    _complete(known), _complete(bare)
    k, b = known.summary['figures'], bare.summary['figures']
    print(f'2 kg payload, gravity compensation over 3 s: configured: drift {k["joint_drift_max_rad"]:.3g} rad, tip '
          f'{k["tip_displacement_m"] * 1e3:.3g} mm; not configured: drift {b["joint_drift_max_rad"]:.3g} rad (1 mrad '
          f'after {b["drift_1mrad_after_s"]:.3f} s), the tip {b["tip_drop_m"] * 1e3:.0f} mm lower')
    assert k['joint_drift_max_rad'] < 1e-3 and k['drift_1mrad_after_s'] is None
    assert b['joint_drift_max_rad'] > 0.1 and b['tip_drop_m'] > 0.05


def test_hybrid_in_the_pose_space_holds_the_tool_vertical_while_pressing(runs):
    """10 N on the table while the line is drawn; the orientation error (the law's, on SO(3)) and the tool's
    tilt from the vertical (its z axis against world -z, from the measured joints) stay < 10 mrad."""
    result = runs.get('iiwa_vertical')
    d, s = result.data, result.summary
    _complete(result)
    exp = exps.get('iiwa_hybrid_vertical')
    f_d = abs(exp.force[0])
    ef = (d.force_reference() - d.force_measured())[d.window(exp.force_window), 0]
    model = exps.IIWA_LINE.model('pose')
    import pinocchio as pin
    tilt = [math.acos(np.clip(-pin.exp3(model.fk(q)[3:])[2, 2], -1.0, 1.0)) for q in d.q[::10]]
    names = list(d.motion_names)
    path = np.linalg.norm(d.motion_error()[:, [names.index('x'), names.index('y')]], axis=1)
    print(f'iiwa hybrid, pose task space: force error after {exp.force_window} s max {np.nanmax(np.abs(ef)):.3g} N; '
          f'orientation error max {s["figures"]["orientation_max_rad"] * 1e3:.4f} mrad, tool tilt max '
          f'{max(tilt) * 1e3:.4f} mrad; path error max {path.max() * 1e3:.4f} mm; y travelled '
          f'{np.ptp(d.ref_pos[:, d.ref_names.index("y")]) * 1e3:.1f} mm')
    assert np.nanmax(np.abs(ef)) < 0.05 * f_d
    assert s['figures']['orientation_max_rad'] < 10e-3 and max(tilt) < 10e-3
    assert path.max() < 2e-3
    assert np.ptp(d.ref_pos[:, d.ref_names.index('y')]) > 0.99 * exps.IIWA_LINE.length


# -- repeatability ----------------------------------------------------------------------------------------
@pytest.mark.parametrize('first,second,name,duration', [
    ('polar', 'polar_again', 'polar_step', 1.7),
    ('force', 'force_again', 'force_steps', 2.3),     # own-tick wrench; a stamped step at 2.0 s
])
def test_lockstep_runs_repeat_exactly(runs, first, second, name, duration):
    a, b = runs.get(first), runs.get(second)
    ia, ib = common_ticks(a.data, b.data)
    assert len(ia) >= MIN_TICKS * a.summary['expected_ticks']
    for field in ('q', 'qd', 'tau_cmd', 'err_pos', 'force_xyz'):
        x, y = getattr(a.data, field)[ia], getattr(b.data, field)[ib]
        same = (x == y) | (np.isnan(x) & np.isnan(y))
        assert same.all(), f'{name}: {field} differs between two lockstep runs at t = {a.data.t[ia][~same.all(axis=1)][:5]}'
    sa = physics_summary(restrict(a.data, ia), name, duration)
    sb = physics_summary(restrict(b.data, ib), name, duration)
    assert sa == sb
    if _complete(a) and _complete(b):
        assert {k: a.summary[k] for k in sa} == {k: b.summary[k] for k in sb}


# -- the recording ---------------------------------------------------------------------------------------
def test_bag_of_a_run_reads_back_with_rosbags(runs):
    """The run's rosbag2 directory (mcap + metadata.yaml) read with rosbags: every topic of the run with its
    type; per-tick topics carry one message per control tick of the run (the bag also holds the ticks after
    the run's end, until the bridge was paused, and re-published states; a share of at most 1 - MIN_TICKS
    may be lost on the way to the recorder under load, see MIN_TICKS)."""
    from rosbags.rosbag2 import Reader
    from rosbags.typesys import Stores, get_typestore
    result = runs.get('polar')
    ticks = result.summary['expected_ticks']
    end_ns = int(round(result.summary['duration_s'] * 1e9))
    bag = result.bag
    assert (bag / 'metadata.yaml').is_file() and list(bag.glob('*.mcap'))
    expected_types = {
        '/joint_states': 'sensor_msgs/msg/JointState', '/robot_joint_commands': 'sensor_msgs/msg/JointState',
        '/ft_sensor/wrench': 'geometry_msgs/msg/WrenchStamped', '/clock': 'rosgraph_msgs/msg/Clock',
        '/controller/reference': 'sensor_msgs/msg/JointState', '/controller/error': 'sensor_msgs/msg/JointState',
        '/controller/joint_trajectory': 'trajectory_msgs/msg/JointTrajectory',
        '/diagnostics': 'diagnostic_msgs/msg/DiagnosticArray', '/rosout': 'rcl_interfaces/msg/Log',
    }
    per_tick = ('/joint_states', '/robot_joint_commands', '/ft_sensor/wrench', '/controller/reference',
                '/controller/error')
    store = get_typestore(Stores.ROS2_JAZZY)
    stamps = {t: [] for t in per_tick}
    with Reader(bag) as reader:
        conns = {c.topic: c for c in reader.connections}
        for topic, msgtype in expected_types.items():
            assert topic in conns, f'{topic} not recorded (bag has {sorted(conns)})'
            assert conns[topic].msgtype == msgtype
        counts = {t: c.msgcount for t, c in conns.items()}
        wanted = [conns[t] for t in (*per_tick, '/controller/joint_trajectory')]
        for conn, _, raw in reader.messages(connections=wanted):
            msg = store.deserialize_cdr(raw, conn.msgtype)
            if conn.topic == '/controller/joint_trajectory':
                assert list(msg.joint_names) == list(scenarios.get('polar_two_link').joints)
                assert msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec == 500_000_000
                continue
            stamps[conn.topic].append(msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec)
    in_run = {t: {k for k in v if k <= end_ns} for t, v in stamps.items()}
    print(f'bag of the polar run ({ticks} ticks): {dict(sorted(counts.items()))}; ticks of the run per topic '
          f'{ {t: len(v) for t, v in in_run.items()} }')
    assert counts['/controller/joint_trajectory'] == 1
    assert counts['/diagnostics'] >= 1 and counts['/rosout'] >= 1
    # /clock: the bridge publishes it every clock_period (its parameter), not every tick
    assert 1 <= counts['/clock'] <= counts['/joint_states']
    cmd = np.array(stamps['/robot_joint_commands'])
    assert np.all(np.diff(cmd) >= 0), 'commands in stamp order (a re-published state is answered again)'
    assert cmd[0] == 0 and cmd[-1] >= end_ns
    for topic in per_tick:
        assert len(in_run[topic]) >= MIN_TICKS * ticks, f'{topic}: {len(in_run[topic])} of {ticks} ticks'
        assert in_run[topic] <= set(range(0, end_ns + 1, 1_000_000)), f'{topic}: stamps off the 1 ms tick grid'
    assert len(in_run['/robot_joint_commands'] & in_run['/joint_states']) >= MIN_TICKS * ticks
