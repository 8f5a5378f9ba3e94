"""Drop-in for a user's ROS 2 system, end to end: the nodes as separate processes over DDS (loopback, a
claimed private domain), lockstep bridges (deterministic), driven like joint_trajectory_controller.

1. Two robots from one shipped config in one domain, each under its own namespace and clock
   (`-r __ns:=/r1 -r /clock:=/r1/clock --params-file config/polar_two_link.yaml`), each following its
   own trajectory; the parameters read back over the parameter services are the file's.
2. A MoveIt-style trajectory on the iiwa: the first point is the current state at 0 s, the others carry
   velocities and accelerations, the joints are named in a shuffled order; followed to 1e-3 rad; its goal
   tolerances met are reported OK on /diagnostics and logged.
3. An empty trajectory sent mid-motion stops the arm where it is and holds it there.
4. A path tolerance violated (a disturbance torque switched on in the bridge mid-trajectory): the
   controller holds the position and /diagnostics reports ERROR naming the joint.
"""
import numpy as np
import pytest

from support import robustness as rh
from support.e2e import E2E_DOMAINS, Lockstep
from robot_control.tools.demo_experiments import IIWA_LINE
from robot_control.tools.processes import DomainClaim

IIWA = ('lbr_iiwa_joint_1', 'lbr_iiwa_joint_2', 'lbr_iiwa_joint_3', 'lbr_iiwa_joint_4', 'lbr_iiwa_joint_5',
        'lbr_iiwa_joint_6', 'lbr_iiwa_joint_7')
POLAR = ('theta1', 'r')
SHUFFLE = (3, 0, 6, 1, 5, 2, 4)                 # the order a planner names the iiwa's joints in
IIWA_BRIDGE = {'initial_positions': list(IIWA_LINE.posture), 'surface.enable': False}
OMEGA_N = 6.0                                   # rad/s, config/iiwa.yaml and polar_two_link.yaml: 0.5 omega_res


def quintic_points(q0, q1, duration, count):
    """MoveIt-like samples of a rest-to-rest quintic from q0 to q1 (n,) over `duration` s: times (count,),
    positions, velocities, accelerations (count, n); the first point is q0 at 0 s."""
    t = np.linspace(0.0, duration, count)
    s = t / duration
    dq = np.asarray(q1) - np.asarray(q0)
    pos = np.asarray(q0) + np.outer(10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5, dq)
    vel = np.outer((30 * s ** 2 - 60 * s ** 3 + 30 * s ** 4) / duration, dq)
    acc = np.outer((60 * s - 180 * s ** 2 + 120 * s ** 3) / duration ** 2, dq)
    return t, pos, vel, acc


@pytest.fixture
def domain():
    with DomainClaim(E2E_DOMAINS, timeout=300.0) as claim:
        yield claim.domain_id


# -- 1. two namespaced robots ---------------------------------------------------------------------------
def test_two_namespaced_robots_from_one_config_follow_their_own_trajectories(tmp_path, domain):
    from rclpy.node import Node
    from rclpy.parameter_client import AsyncParameterClient
    from sensor_msgs.msg import JointState
    from trajectory_msgs.msg import JointTrajectory
    from robot_control.ros import conversions
    from robot_control.ros.qos import REFERENCE_QOS
    goals = {'/r1': np.array([0.5, 0.7]), '/r2': np.array([-0.4, 0.3])}
    with rh.processes() as procs, rh.ros_test_context(domain) as (ctx, ex):
        node = Node('two_robots_test', context=ctx)
        ex.add_node(node)
        last = {}       # namespace -> (stamp ns, q) of its newest joint_states

        def on_state(ns):
            return lambda m: last.__setitem__(ns, (conversions.stamp_to_ns(m.header.stamp), np.array(m.position)))
        subs = [node.create_subscription(JointState, f'{ns}/joint_states', on_state(ns), rh._qos(10)) for ns in goals]
        pubs = {ns: node.create_publisher(JointTrajectory, f'{ns}/controller/joint_trajectory', REFERENCE_QOS)
                for ns in goals}
        for ns in goals:
            procs.append(rh.bridge(domain, tmp_path, namespace=ns, mode='lockstep'))
            procs.append(rh.controller(domain, tmp_path, namespace=ns))
        # the loops run once both nodes are up; a trajectory is taken once its controller has a state
        running = lambda: (len(last) == 2 and all(p.get_subscription_count() for p in pubs.values())  # noqa: E731
                           and all(s.get_publisher_count() for s in subs))
        assert rh.spin_until(ex, running, 90.0), [p.output() for p in procs]
        started = {ns: last[ns][0] for ns in goals}
        assert rh.spin_until(ex, lambda: all(last[ns][0] > started[ns] + 0.05 * rh.NS for ns in goals), 30.0)
        for (ns, goal), order in zip(goals.items(), ([0, 1], [1, 0])):     # /r2 names the joints (r, theta1)
            pubs[ns].publish(conversions.joint_trajectory([POLAR[i] for i in order], [0.5], [goal[order]]))
        sent = {ns: last[ns][0] for ns in goals}
        # at least 1.5 s of simulated time after the publication, then until the goal is reached or 10 s have
        # passed (a busy machine may hand the trajectory over some ticks after `sent`: it starts there)
        reached = lambda ns: np.all(np.abs(last[ns][1] - goals[ns]) < 1e-3)           # noqa: E731
        done = lambda: all(last[ns][0] > sent[ns] + 1.5 * rh.NS                        # noqa: E731
                           and (reached(ns) or last[ns][0] > sent[ns] + 10 * rh.NS) for ns in goals)
        assert rh.spin_until(ex, done, 120.0), {ns: last[ns][0] / rh.NS for ns in goals}
        final = {ns: last[ns][1] for ns in goals}
        params = {}
        for ns in goals:
            client = AsyncParameterClient(node, f'{ns}/controller')
            assert rh.spin_until(ex, client.services_are_ready, 30.0)
            future = client.get_parameters(['model_params.gravity', 'use_sim_time', 'scenario', 'joints'])
            assert rh.spin_until(ex, future.done, 30.0)
            params[ns] = [v for v in future.result().values]
        logs = {p.name: p.output() for p in procs}
    for ns, goal in goals.items():
        err = np.abs(final[ns] - goal)
        print(f'{ns}: final |q - q_goal| = {err.tolist()} (at least 1 s after the end of its 0.5 s trajectory)')
        assert np.all(err < 1e-3), (ns, final[ns], goal)
        gravity, sim_time, scenario, joints = params[ns]
        assert gravity.double_value == 9.8 and sim_time.bool_value is True, (ns, gravity, sim_time)
        assert scenario.string_value == 'polar_two_link' and list(joints.string_array_value) == list(POLAR)
        text = logs[f'controller{ns.replace("/", "_")}']
        assert 'trajectory accepted' in text and '[WARN]' not in text and '[ERROR]' not in text, text


# -- 2. a MoveIt-style trajectory on the iiwa; its goal reported --------------------------------------------
MOVE = np.array([0.5, -0.3, 0.4, 0.3, -0.5, 0.4, 0.6])     # rad, from IIWA_LINE.posture
MOVE_TIME = 1.0                                            # s
SETTLE = 0.3                                               # s after the trajectory's end
GOAL_TOLERANCE = 1e-3                                      # rad, every joint


@pytest.fixture(scope='module')
def moveit_run(tmp_path_factory):
    """The iiwa follows quintic_points (11 points, 0.1 s apart) named in the SHUFFLE order, goal tolerances
    GOAL_TOLERANCE with goal_time 0.5 s; the trajectory starts at t = 0 (the first point: the state there)."""
    goal_rows = {f'constraints.{j}.goal': GOAL_TOLERANCE for j in IIWA}
    with DomainClaim(E2E_DOMAINS, timeout=300.0) as claim, \
            Lockstep(claim.domain_id, tmp_path_factory.mktemp('moveit') / 'logs', 'iiwa', IIWA_BRIDGE,
                     {'constraints.goal_time': 0.5, **goal_rows}) as run:
        _, q, _ = run.states()
        q0 = q[-1]
        times, pos, vel, acc = quintic_points(q0, q0 + MOVE, MOVE_TIME, 11)
        order = list(SHUFFLE)
        run.send_trajectory([IIWA[i] for i in order], times, pos[:, order], vel[:, order], acc[:, order])
        run.advance(MOVE_TIME + SETTLE)
        return q0, run.states(), run.references(), run.diagnostics(': trajectory'), run.log()


def test_a_moveit_style_trajectory_in_shuffled_joint_order_is_followed_to_1e_3_rad(moveit_run):
    q0, (t, q, _), (t_ref, q_ref, _), _, _ = moveit_run
    goal = q0 + MOVE
    times, pos, _, _ = quintic_points(q0, goal, MOVE_TIME, 101)
    # the reference is the planner's curve (exact quintic through the points' positions, velocities, accelerations)
    on_path = (t_ref > 0) & (t_ref <= MOVE_TIME)
    path = np.array([np.interp(t_ref[on_path], times, pos[:, j]) for j in range(7)]).T
    ref_dev = np.abs(q_ref[on_path] - path).max()
    tracking = np.abs(q[(t >= 0) & (t <= MOVE_TIME)] - np.array(
        [np.interp(t[(t >= 0) & (t <= MOVE_TIME)], times, pos[:, j]) for j in range(7)]).T).max()
    final = np.abs(q[-1] - goal)
    print(f'iiwa MoveIt-style trajectory: largest tracking error {tracking:.3g} rad, final |q - q_goal| '
          f'{final.max():.3g} rad at t = {t[-1]:.3f} s ({SETTLE} s after its end); reference within '
          f'{ref_dev:.2g} rad of the planned curve')
    assert t[-1] >= MOVE_TIME + SETTLE
    assert ref_dev < 2e-4          # linear interpolation of the 101 samples
    assert np.all(final < 1e-3), final


def test_a_goal_reached_within_its_tolerances_is_reported_ok_and_logged(moveit_run):
    _, _, _, statuses, log = moveit_run
    level, message, values = statuses[-1]
    print(f'/diagnostics after the goal: {level} "{message}"')
    assert level == 'OK' and values['outcome'] == 'succeeded', statuses[-1]
    assert float(values['goal_tolerance.lbr_iiwa_joint_4']) == GOAL_TOLERANCE
    assert any(line.startswith('trajectory succeeded: goal reached') for line in log), log
    assert not any(s[0] != 'OK' for s in statuses), [s for s in statuses if s[0] != 'OK']


# -- 3. an empty trajectory stops the arm mid-motion ------------------------------------------------------
CANCEL_AT = 0.45     # s, mid-motion
HOLD = 1.5           # s after the cancel


def test_an_empty_trajectory_mid_motion_stops_the_arm_where_it_is_and_holds(tmp_path, domain):
    with Lockstep(domain, tmp_path / 'logs', 'iiwa', IIWA_BRIDGE) as run:
        _, q, _ = run.states()
        times, pos, vel, acc = quintic_points(q[-1], q[-1] + MOVE, MOVE_TIME, 11)
        run.send_trajectory(IIWA, times, pos, vel, acc)
        run.advance(CANCEL_AT)
        t, q, qd = run.states()           # paused: the controller's last state is the bridge's newest
        t_c, q_c, qd_c = t[-1], q[-1], qd[-1]
        run.send_trajectory(IIWA, [], np.zeros((0, 7)))
        run.advance(t_c + HOLD)
        t, q, _ = run.states()
        t_ref, q_ref, qd_ref = run.references()
    after = t > t_c
    tau, drift = t[after] - t_c, np.abs(q[after] - q_c)
    # held at q_c from speed v, the critically damped error equation gives |q - q_c| = |v| tau exp(-omega_n tau)
    envelope = np.abs(qd_c) * (tau * np.exp(-OMEGA_N * tau))[:, None]
    ratio = (drift.max(axis=0) / envelope.max(axis=0))
    final = drift[-1]
    print(f'empty trajectory at t = {t_c:.3f} s (speeds up to {np.abs(qd_c).max():.3g} rad/s, '
          f'{np.abs(q_c - pos[-1]).max():.3g} rad short of the goal): largest drift {drift.max():.3g} rad '
          f'({ratio.max():.3f} x |v|/(e omega_n)), largest excess over |v| tau exp(-omega_n tau) '
          f'{(drift - envelope).max():.2g} rad, |q - q_cancel| {final.max():.2g} rad after {HOLD} s')
    assert np.abs(qd_c).max() > 0.3 and np.abs(q_c - pos[-1]).max() > 0.2      # really mid-motion
    held = t_ref > t_c
    assert np.all(q_ref[held] == q_c) and np.all(qd_ref[held] == 0.0)       # the reference is the cancel state
    assert np.all(drift <= 1.05 * envelope + 1e-4), (drift - envelope).max(axis=0)
    assert np.all(final < 1e-3), final


# -- 4. a path tolerance violated -------------------------------------------------------------------------
PUSH = (0.35, 0.1)      # s: a 20 N m disturbance torque on theta1 from 0.35 s, for 0.1 s


def test_a_violated_path_tolerance_holds_the_position_and_reports_error_naming_the_joint(tmp_path, domain):
    goal = np.array([0.8, 0.9])
    tolerance = {'constraints.theta1.trajectory': 0.01, 'constraints.r.trajectory': 0.01}
    with Lockstep(domain, tmp_path / 'logs', 'polar_two_link', {}, tolerance) as run:
        run.send_trajectory(POLAR, [1.0], [goal])
        t_on = run.advance(PUSH[0])
        run.set_bridge(disturbance__joint_torque=[20.0, 0.0])
        t_off = run.advance(t_on + PUSH[1])
        run.set_bridge(disturbance__joint_torque=[0.0, 0.0])
        t_end = run.advance(2.0)
        t, q, _ = run.states()
        t_ref, q_ref, qd_ref = run.references()
        statuses = run.diagnostics(': trajectory')
        errors = run.log(40)
    # the bridge paused itself at each time (its pause_at), however slowly this process ran beside it: the push
    # lasted 0.1 s of simulation and the hold 1.55 s
    times = [t_on, t_off, t_end]
    assert np.allclose(times, [PUSH[0], PUSH[0] + PUSH[1], 2.0], rtol=0.0, atol=1e-9), times
    level, message, values = statuses[-1]
    print(f'/diagnostics: {level} "{message}"; controller ERROR log: {errors}')
    assert level == 'ERROR' and values['outcome'] == 'path' and 'theta1: |q_d - q|' in message, statuses[-1]
    assert 'r: |q_d' not in message
    assert any('trajectory path: trajectory tolerance exceeded' in line and 'theta1' in line for line in errors)
    # from the violation on the reference stands still where the robot was, far short of the goal
    t_v = float(message.split('exceeded at t = ')[1].split(' s')[0])
    assert t_on < t_v <= t_off, (t_on, t_v, t_off)
    held = t_ref > t_v
    q_hold = q_ref[held][0]
    assert np.all(q_ref[held] == q_hold) and np.all(qd_ref[held] == 0.0)
    assert np.allclose(q_hold, q[np.searchsorted(t, t_v)], atol=0.0), (q_hold, q[np.searchsorted(t, t_v)])
    final = np.abs(q[-1] - q_hold)
    print(f'path tolerance 0.01 rad exceeded at t = {t_v:.3f} s; held at {q_hold.tolist()} '
          f'({np.abs(goal - q_hold).tolist()} short of the goal); |q - q_hold| {final.max():.2g} at t = {t[-1]:.3f} s')
    assert np.all(np.abs(goal - q_hold) > 0.1)
    assert np.all(final < 1e-3), final
