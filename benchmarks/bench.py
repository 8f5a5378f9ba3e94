"""Benchmarks: control-law cost, closed-loop rate and latency over DDS, physics rate, against targets.

    python -m benchmarks.bench [--quick] [--out out/bench] [--only b1,b2,b3,b4] [--cpu-wakeup-latency US|none]
                               [--domain-id N]

Writes <out>/results.json (flat: metric name -> number), <out>/machine.json (CPU, cores, versions),
<out>/results.md (the table for the README) and prints the table; child process logs go to
<out>/logs/. Every figure is a median over repeated runs after a warm-up; every ratio is
taken between figures measured side by side in the same run (B1 interleaves its cases round by
round, B2 interleaves ping-pong, polar and iiwa runs).

B1 law cost per control tick, us (median, p99): what the controller pays for its law each tick,
   law.errors(state, ref) + law.torque(state, ref, err, int_E) of the Law a ControllerConfig builds (the
   State measured as the core measures it, the Reference's arrays reused from tick to tick as the core's
   are; LawTick): 2-DOF closed-form computed torque, 7-DOF iiwa computed torque, operational-space hybrid
   (force on z against the table) and Cartesian impedance (pose task space) through Pinocchio. The targets
   are on each law's median over the median of the floor pinocchio.rnea (the iiwa's inverse dynamics) in
   the same run (law_vs_rnea_*). Beside them, without a target, each law's public function on the same
   inputs (laws.computed_torque, hybrid, impedance: the same torques, plus the check of every argument
   on every call, which the controller does once, at configuration: law_us_*_checked_*), and the peer
   modern_robotics.ComputedTorque on the same iiwa and inputs (torques checked equal to computed_torque's
   within 1e-8; speedup_vs_modern_robotics against the checked function, function against function).
B2 lockstep closed loop over DDS (benchmarks.bench_ros), against a bare rclpy ping-pong; also
   the CPU time of both processes per step, which the other load of a shared machine hardly moves. The cost
   of the realism: the iiwa with its typical profile (config/realism/iiwa_typical.yaml) against the ideal
   iiwa, round by round (lockstep_typical_vs_ideal_ratio_iiwa >= 0.9).
B3 real time at 1 kHz (benchmarks.bench_ros): the polar arm, the iiwa under computed torque,
   hybrid control on the table, Cartesian impedance and computed torque on the iiwa's typical realism
   profile, each in rounds alternating with the floor (the bare exchange of the run's messages at 1 kHz
   without physics and law: states and commands, and the wrench stream for the hybrid run), so that both see
   the machine's load of the same minute; the targets hold for each run: missed periods at most 1.5 times its
   floor's over as many periods (a floor of 0 allows 1), p99
   latency <= 1 ms, real-time factor >= 0.99.
CPU wake-up: B3 holds a CPU wake-up latency request of 0 us (--cpu-wakeup-latency; robot_control.ros.wakeup, the
   nodes' flag of the same name), as a realtime setup does and as cyclictest does while it measures: the floors and
   the loops alike then run without the idle-state exits that otherwise add up to about 100 us to a tick on a VM.
   B2 (lockstep, a simulation's pace rather than a deadline) runs without. machine.json records it.
Engines: B2 and B3 also run the iiwa under computed torque on MuJoCo (their keys end in _iiwa_mujoco), held to
   the same targets as the runs on PyBullet.
B4 the World of the iiwa without ROS, on PyBullet and on MuJoCo (sim_bridge.engines), rounds interleaved: physics
   steps per second under torque control (set_torque, step, state), the table in the world on both; the target is
   on MuJoCo's rate over PyBullet's in the same run (sim_steps_mujoco_vs_pybullet).
B5 sweep throughput (benchmarks.bench_sweep): the iiwa under computed torque on the typical profile, 3 s
   episodes; the sweep's ticks/s on the local worker processes (one per core) and on a two-host Ray cluster
   (two network namespaces, one CPU each; where namespaces can be made) over one episode's tick rate in
   process times the cores used, over 200 episodes, the workers' start included (on Ray, fresh processes that
   import the package and PyBullet for their first episode: about 3 s of a run's wall time, a third of a run of
   40 episodes here); and the wall time of 1,000 episodes locally (the full run runs them; --quick scales
   a shorter run).

`make bench` runs it (`make bench QUICK=1` with --quick). --quick runs seconds instead of minutes
and still writes every key. ROS processes run with
ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST on a domain id private to this run (the first free of 101, 100, ..., 1).
"""
import argparse
import contextlib
import dataclasses
import json
from importlib import metadata
import math
import os
import platform
import signal
import sys
import time

import numpy as np

from benchmarks.bench_ros import REALTIME_RUNS, RUN_ENGINES
from robot_control.ros import wakeup
from robot_control.tools import processes

#: B1's laws: case -> key stem of their figures
LAWS = {'ct_2dof': 'law_us_ct_2dof', 'ct_7dof': 'law_us_ct_7dof', 'hybrid_7dof': 'law_us_hybrid_7dof',
        'impedance_7dof': 'law_us_impedance_7dof'}
#: B1's laws for a real arm (benchmarks.bench_real_arm)
LAWS.update({'joint_impedance_7dof': 'law_us_joint_impedance_7dof', 'adaptive_7dof': 'law_us_adaptive_7dof'})
#: the targets: key -> (comparison, bound); the table marks each figure met or MISSED. Ratios of figures of
#: the same run wherever the figure depends on the machine; latency and real-time factor are the loop's
#: own requirements at 1 kHz.
TARGETS = {
    'law_vs_rnea_ct_2dof': ('<=', 8.0),
    'law_vs_rnea_ct_7dof': ('<=', 8.0),
    'law_vs_rnea_hybrid_7dof': ('<=', 30.0),
    'law_vs_rnea_impedance_7dof': ('<=', 30.0),
    'law_vs_rnea_joint_impedance_7dof': ('<=', 8.0),
    'law_vs_rnea_adaptive_7dof': ('<=', 30.0),
    'speedup_vs_modern_robotics': ('>=', 20.0),
    'lockstep_vs_pingpong_ratio': ('>=', 0.8),
    'lockstep_typical_vs_ideal_ratio_iiwa': ('>=', 0.9),
    'realtime_missed_vs_floor': ('<=', 1.5),
    'realtime_latency_p99_ms': ('<=', 1.0),
    'realtime_rtf': ('>=', 0.99),
    'sweep_local_vs_episode_ratio': ('>=', 0.8),
    'sweep_ray_vs_episode_ratio': ('>=', 0.7),
    'sweep_local_1000_s': ('<=', 60.0),
    'sim_steps_mujoco_vs_pybullet': ('>=', 1.0),
}
#: B2's target holds for each of its runs on another engine
TARGETS.update({f'lockstep_vs_pingpong_ratio_{_run}': TARGETS['lockstep_vs_pingpong_ratio'] for _run in RUN_ENGINES})
#: B3's targets hold for each of its runs as well
for _run in REALTIME_RUNS:
    TARGETS.update({f'realtime_missed_vs_floor_{_run}': TARGETS['realtime_missed_vs_floor'],
                    f'realtime_latency_p99_ms_{_run}': TARGETS['realtime_latency_p99_ms'],
                    f'realtime_rtf_{_run}': TARGETS['realtime_rtf']})
#: share of its periods the floor of B3 answers in time on an idle machine fit for 1 kHz; below it the summary
#: warns that B3's absolute figures measure the machine and its load as much as the loop
QUIET_FLOOR = 0.99
#: what a ratio is made of, printed beside its verdict: key -> format of the results
BESIDE = {f'law_vs_rnea_{case}': f'{{{stem}_median:.3g}} us / rnea {{pin_rnea_us_median:.3g}} us'
          for case, stem in LAWS.items()}
BESIDE.update({f'realtime_missed_vs_floor_{_run}': f'{{realtime_missed_periods_{_run}:.0f}} of '
               f'{{realtime_periods_{_run}:.0f}} periods missed, floor {{realtime_floor_missed_periods_{_run}:.0f}} '
               f'of {{realtime_floor_periods_{_run}:.0f}}' for _run in REALTIME_RUNS})
BESIDE.update({'sweep_local_vs_episode_ratio': '1 episode {sweep_episode_ticks_per_s:,.0f} ticks/s in process',
               'sweep_local_1000_s': 'measured {sweep_local_s:.1f} s for the run\'s episodes'})
BESIDE['lockstep_typical_vs_ideal_ratio_iiwa'] = ('median of the rounds; medians {lockstep_steps_per_s_iiwa_typical:.0f} '
                                                  '/ {lockstep_steps_per_s_iiwa:.0f} steps/s')
BESIDE.update({f'lockstep_vs_pingpong_ratio_{_run}': f'{{lockstep_steps_per_s_{_run}:.0f}} steps/s / ping-pong '
               '{pingpong_roundtrips_per_s:.0f} round trips/s' for _run in RUN_ENGINES})
#: tolerance of the modern_robotics cross-check, N m
MR_TOLERANCE = 1e-8
SEED = 6


@dataclasses.dataclass(frozen=True)
class Plan:
    """How long each part runs."""

    law_rounds: int          # B1 rounds (after one warm-up round), cases interleaved per round
    law_calls: int           # B1 calls per case per round (one input each)
    mr_calls: int            # B1 modern_robotics calls per round (about 30 ms each)
    world_rounds: int        # B4 rounds of world_steps steps
    world_steps: int
    dds_rounds: int          # B2 rounds: ping-pong, polar, iiwa each once per round
    dds_warmup_s: float      # B2/B3 wall time discarded after the first state
    dds_window_s: float      # B2 measured window per run
    realtime_s: float        # B3 measured duration per scenario (and of its floor)
    realtime_rounds: int     # B3 rounds per scenario, each a floor then the scenario for realtime_s / rounds
    sweep_episodes: int      # B5 episodes of the timed local run
    sweep_ratio_episodes: int  # B5 episodes of each ratio's sweep (local, Ray)
    sweep_single: int        # B5 episodes in process before and after each ratio's sweep (each)


FULL = Plan(law_rounds=10, law_calls=400, mr_calls=10, world_rounds=7, world_steps=2000,
            dds_rounds=5, dds_warmup_s=1.0, dds_window_s=3.0, realtime_s=20.0, realtime_rounds=4,
            sweep_episodes=1000, sweep_ratio_episodes=200, sweep_single=2)
QUICK = Plan(law_rounds=3, law_calls=100, mr_calls=2, world_rounds=3, world_steps=300,
             dds_rounds=1, dds_warmup_s=0.3, dds_window_s=1.0, realtime_s=2.0, realtime_rounds=2,
             sweep_episodes=6, sweep_ratio_episodes=6, sweep_single=1)


# -- statistics ----------------------------------------------------------------------------------
def median_p99_us(ns):
    """(median, 99th percentile) of durations in ns, as microseconds."""
    a = np.asarray(ns, dtype=float) / 1e3
    return float(np.median(a)), float(np.percentile(a, 99))


def time_calls(fn, inputs, out, before=None):
    """Call fn(*args) for each args in `inputs`, appending each call's wall time (ns) to `out`; before(*args),
    when given, runs first for each, untimed."""
    clock = time.perf_counter_ns
    for args in inputs:
        if before is not None:
            before(*args)
        t0 = clock()
        fn(*args)
        out.append(clock() - t0)


# -- B1: control laws ----------------------------------------------------------------------------
KP, KV, KI = 36.0, 12.0, 10.0     # 1/s^2, 1/s, 1/s^3 (the lecture's example, plus integral action)


def _iiwa_states(model, rng, count):
    """`count` random (q, qd, q_d, qd_d, qdd_d, eint) of the iiwa inside 80 % of its joint range."""
    lo, hi = model.position_limits
    states = []
    for _ in range(count):
        q = rng.uniform(0.8 * lo, 0.8 * hi)
        states.append((q, rng.normal(0, 1, 7), q + rng.normal(0, 0.1, 7), rng.normal(0, 1, 7),
                       rng.normal(0, 1, 7), rng.normal(0, 0.01, 7)))
    return states


class LawTick:
    """The law's part of one control tick, as ControllerCore.update_checked runs it: err = law.errors(state,
    ref), then law.torque(state, ref, err, int_E), for the Law the ControllerConfig `config` built. Called as
    (state, ref_values, int_E); load(), with the same arguments and untimed, first copies ref_values (q_d,
    qd_d, qdd_d and for a law that uses force f_d, fd_d, fdd_d) into the arrays of the one Reference it
    holds, as the core's References sample in place (the same arrays every tick; no task target, no
    wrench)."""

    def __init__(self, config):
        from robot_control.laws import Reference
        self.law = law = config.control_law
        n, k = config.n, len(law.force_task.force_axes)
        force = (np.zeros(k), np.zeros(k), np.zeros(k)) if k else (None, None, None)
        self.ref = Reference(np.zeros(n), np.zeros(n), np.zeros(n), *force)

    def load(self, state, ref_values, int_E):
        for buffer, values in zip(self.ref, ref_values):
            buffer[...] = values

    def __call__(self, state, ref_values, int_E):
        law, ref = self.law, self.ref
        return law.torque(state, ref, law.errors(state, ref), int_E)


def law_tick(config, rows, f_meas=None):
    """(LawTick of `config`, its inputs (state, ref_values, int_E)) for rows (q, qd, ref_values, int_E): each
    State measured as the core measures it (robot_control.core.tick.measure_task; f_meas (m,) the force
    sensor's reading, N, or None), at t = 1 ms per row."""
    from robot_control.core.tick import measure_task
    from robot_control.laws import State
    tick = LawTick(config)
    inputs = []
    for k, (q, qd, ref_values, int_E) in enumerate(rows):
        task = measure_task(config, q, qd, f_meas) if tick.law.needs_task_space else ()
        inputs.append((State(1e-3 * k, q, qd, *task), ref_values, int_E))
    return tick, inputs


def law_cases(count):
    """{name: (fn, inputs)} of B1, on the same iiwa model and inputs: per law its per-tick case (a LawTick)
    and its public checked function (name + '_checked'); the modern_robotics peer (torques checked equal
    to the checked computed_torque), the floor pinocchio.rnea."""
    import modern_robotics as mr
    import pinocchio as pin

    from benchmarks.bench_mr import mr_chain
    from benchmarks.bench_real_arm import real_arm_cases
    from robot_control.core.config import ControllerConfig
    from robot_control.gains import ServoGains
    from robot_control.laws import computed_torque
    from robot_control.laws.servo import gain_params as servo_params
    from robot_control.models import for_scenario, make_model

    rng = np.random.default_rng(SEED)
    iiwa = for_scenario('iiwa')
    states = _iiwa_states(iiwa, rng, count)
    gains7 = ServoGains.uniform(7, KP, KV, KI)
    # modern_robotics integrates eint + e (its ComputedTorque adds the current error): same int_E
    ct7 = [(iiwa, q, qd, q_d, qd_d, qdd_d, gains7, eint + (q_d - q)) for q, qd, q_d, qd_d, qdd_d, eint in states]
    Mlist, Glist, Slist, g = mr_chain(iiwa.model)
    mr_in = [(q, qd, eint, g, Mlist, Glist, Slist, q_d, qd_d, qdd_d, KP, KI, KV)
             for q, qd, q_d, qd_d, qdd_d, eint in states]
    check_mr_equal(computed_torque, ct7, mr.ComputedTorque, mr_in)

    polar = make_model('polar_two_link', m=2.0, gravity=9.8)
    gains2 = ServoGains.uniform(2, KP, KV)
    ct2 = [(polar, np.array([rng.uniform(-1, 1), rng.uniform(0.3, 0.8)]), rng.normal(0, 1, 2),
            rng.normal(0, 1, 2), rng.normal(0, 1, 2), rng.normal(0, 1, 2), gains2) for _ in range(count)]

    data = iiwa.model.createData()
    rnea = [(iiwa.model, data, q, qd, qdd_d) for q, qd, _, _, qdd_d, _ in states]
    return {'ct_2dof': law_tick(ControllerConfig(polar, law_params=servo_params(gains2)),
                                [(q, qd, (q_d, qd_d, qdd_d), None) for _, q, qd, q_d, qd_d, qdd_d, _ in ct2]),
            'ct_2dof_checked': (computed_torque, ct2),
            'ct_7dof': law_tick(ControllerConfig(iiwa, law_params=servo_params(gains7), integral=True),
                                [(q, qd, (q_d, qd_d, qdd_d), int_E) for _, q, qd, q_d, qd_d, qdd_d, _, int_E in ct7]),
            'ct_7dof_checked': (computed_torque, ct7),
            **hybrid_cases(iiwa, states),
            **impedance_cases(for_scenario('iiwa', task_space='pose'), states),
            **real_arm_cases(iiwa, states),
            'mr_ct_7dof': (mr.ComputedTorque, mr_in), 'pin_rnea': (pin.rnea, rnea)}


#: the hybrid case's contact: the iiwa scenario's table, stiffness N/m and height m; the force the sensor
#: reads and the force reference on z, N
K_E, X_E, F_SENSED, F_D = 20000.0, 0.25, -8.0, -10.0


def hybrid_cases(iiwa, states):
    """B1's hybrid cases on the iiwa, force on z against the table, x and y following the joint reference in
    the task space, posture q_d: 'hybrid_7dof', the law of its ControllerConfig per tick, and
    'hybrid_7dof_checked', laws.hybrid on the same inputs."""
    from robot_control.core.config import ControllerConfig
    from robot_control.gains import ServoGains
    from robot_control.laws import hybrid
    from robot_control.laws.force_task import gain_params
    from robot_control.laws.servo import gain_params as servo_params
    force_gains = ServoGains.uniform(1, KP, KV)
    config = ControllerConfig(iiwa, law='hybrid', law_params={
        **servo_params(ServoGains.uniform(3, KP, KV)), 'force_axes': ('z',), 'k_e': (K_E,), 'x_e': (X_E,),
        **gain_params(force_gains)})
    axes = config.control_law.force_task.mask
    posture = config.law_params.posture.gains(iiwa.n)
    tick, inputs = law_tick(config, [(q, qd, (q_d, qd_d, qdd_d, F_D, 0.0, 0.0), None)
                                     for q, qd, q_d, qd_d, qdd_d, _ in states], np.where(axes, F_SENSED, 0.0))
    checked = []
    for (state, _, _), (q, qd, q_d, qd_d, qdd_d, _) in zip(inputs, states):
        f, fdot = np.zeros(3), np.zeros(3)
        f[axes], fdot[axes] = state.f, state.fdot
        checked.append((iiwa, q, qd, *iiwa._task_motion(q_d, qd_d, qdd_d), np.where(axes, F_D, 0.0), np.zeros(3),
                        np.zeros(3), f, fdot, axes, K_E, config.control_law.motion_gains, force_gains, q_d, posture))
    return {'hybrid_7dof': (tick, inputs), 'hybrid_7dof_checked': (hybrid, checked)}


#: stiffness of the impedance case: x, y, z N/m, rx, ry, rz N m/rad
STIFFNESS = (1000.0, 1000.0, 1000.0, 100.0, 100.0, 100.0)


def impedance_cases(model, states):
    """B1's impedance cases on the iiwa in the pose task space, the target the joint reference in the task
    space, designed damping (ratio 1), posture q_d, the law's bounds of the pose error: 'impedance_7dof', the
    law of its ControllerConfig per tick, and 'impedance_7dof_checked', laws.impedance on the same inputs."""
    from robot_control.core.config import ControllerConfig
    from robot_control.laws import impedance
    config = ControllerConfig(model, law='impedance', law_params={'cartesian_stiffness': STIFFNESS,
                                                                   'cartesian_damping_ratio': 1.0})
    params = config.law_params
    tick, inputs = law_tick(config, [(q, qd, (q_d, qd_d, qdd_d), None) for q, qd, q_d, qd_d, qdd_d, _ in states])
    posture = params.posture.gains(model.n)
    checked = [(model, q, qd, *model._task_motion(q_d, qd_d, qdd_d), STIFFNESS, params.cartesian_damping_ratio,
                None, None, q_d, posture, params.max_pose_error) for q, qd, q_d, qd_d, qdd_d, _ in states]
    return {'impedance_7dof': (tick, inputs), 'impedance_7dof_checked': (impedance, checked)}


def check_mr_equal(ours, our_inputs, peer, peer_inputs):
    """RuntimeError unless our torques equal the peer's within MR_TOLERANCE on every input."""
    worst = max(float(np.max(np.abs(ours(*a) - peer(*b)))) for a, b in zip(our_inputs, peer_inputs))
    if not worst <= MR_TOLERANCE:
        raise RuntimeError(f'modern_robotics: torques differ by {worst:g} N m > {MR_TOLERANCE:g}')
    return worst


def bench_laws(plan):
    """B1 metrics: cases interleaved round by round; the first round is a warm-up."""
    cases = law_cases(plan.law_calls)
    times = {name: [] for name in cases}
    for r in range(plan.law_rounds + 1):
        for name, (fn, inputs) in cases.items():
            calls = inputs[:plan.mr_calls] if name == 'mr_ct_7dof' else inputs
            time_calls(fn, calls, times[name] if r else [], getattr(fn, 'load', None))
    stats = {name: median_p99_us(ns) for name, ns in times.items()}
    rnea = stats['pin_rnea'][0]
    out = {}
    for name, key in LAWS.items():
        out[f'{key}_median'], out[f'{key}_p99'] = stats[name]
        out[f'law_vs_rnea_{name}'] = vs_rnea(stats[name][0], rnea)
        out[f'{key}_checked_median'], out[f'{key}_checked_p99'] = stats[f'{name}_checked']
    for name, key in (('mr_ct_7dof', 'mr_ct_7dof_us'), ('pin_rnea', 'pin_rnea_us')):
        out[f'{key}_median'], out[f'{key}_p99'] = stats[name]
    out['speedup_vs_modern_robotics'] = out['mr_ct_7dof_us_median'] / out['law_us_ct_7dof_checked_median']
    return out


def vs_rnea(law_us, rnea_us):
    """A law's cost in units of Pinocchio's RNEA on the iiwa, timed in the same run: law_us / rnea_us."""
    return law_us / rnea_us


def bench_transport(plan):
    """B1 transport: a 7-joint sensor_msgs/JointState (positions, velocities, efforts) and a
    geometry_msgs/WrenchStamped (a new stamp and new values each) from their CDR bytes, by the package's
    decoders (robot_control.ros.cdr) and by rclpy's deserialize_message, interleaved round by round; the
    first round is a warm-up."""
    from geometry_msgs.msg import WrenchStamped
    from rclpy.serialization import deserialize_message, serialize_message
    from sensor_msgs.msg import JointState

    from robot_control.ros import cdr, conversions

    rng = np.random.default_rng(SEED)
    names = [f'lbr_iiwa_joint_{i}' for i in range(1, 8)]
    states = [serialize_message(conversions.joint_state(names, stamp_ns=1_000_000 * (k + 1),
                                                        position=rng.normal(size=7), velocity=rng.normal(size=7),
                                                        effort=rng.normal(size=7)))
              for k in range(plan.law_calls)]
    wrenches = [serialize_message(conversions.wrench_stamped(rng.normal(size=3), rng.normal(size=3),
                                                             stamp_ns=1_000_000 * (k + 1), frame_id='world'))
                for k in range(plan.law_calls)]
    decoder = cdr.JointStateDecoder()
    cases = {'js7_decode_us_cdr': (decoder.decode, [(m,) for m in states]),
             'js7_decode_us_rclpy': (deserialize_message, [(m, JointState) for m in states]),
             'wrench_decode_us_cdr': (cdr.decode_wrench, [(m,) for m in wrenches]),
             'wrench_decode_us_rclpy': (deserialize_message, [(m, WrenchStamped) for m in wrenches])}
    times = {name: [] for name in cases}
    for r in range(plan.law_rounds + 1):
        for name, (fn, inputs) in cases.items():
            time_calls(fn, inputs, times[name] if r else [])
    out = {}
    for name, ns in times.items():
        out[f'{name}_median'], out[f'{name}_p99'] = median_p99_us(ns)
    return out


# -- B4: the world without ROS -------------------------------------------------------------------
def bench_world(plan):
    """B4: iiwa World physics steps per second (set_torque, step, state per step) on each engine, rounds interleaved;
    MuJoCo's over PyBullet's."""
    from robot_control.models import for_scenario
    from sim_bridge.engines import make_world

    worlds = {'': make_world('pybullet', 'iiwa'), '_mujoco': make_world('mujoco', 'iiwa')}
    try:
        q0 = worlds[''].state()[0]
        tau = for_scenario('iiwa').g(q0)          # gravity hold: the arm stays where it starts
        rates = {key: [] for key in worlds}
        for r in range(plan.world_rounds + 1):
            for key, world in worlds.items():
                t0 = time.perf_counter_ns()
                for _ in range(plan.world_steps):
                    world.set_torque(tau)
                    world.step()
                    world.state()
                if r:
                    rates[key].append(plan.world_steps * 1e9 / (time.perf_counter_ns() - t0))
    finally:
        for world in worlds.values():
            world.close()
    out = {f'sim_steps_per_s_iiwa{key}': float(np.median(v)) for key, v in rates.items()}
    out['sim_steps_mujoco_vs_pybullet'] = out['sim_steps_per_s_iiwa_mujoco'] / out['sim_steps_per_s_iiwa']
    return out


# -- machine, output -----------------------------------------------------------------------------
def machine_info():
    """CPU model, core count, memory and software versions of this run."""
    info = {'cpu_model': platform.processor() or 'unknown', 'cores': os.cpu_count(),
            'python': platform.python_version(), 'platform': platform.platform()}
    try:
        with open('/proc/cpuinfo', encoding='utf-8') as f:
            for line in f:
                if line.startswith('model name'):
                    info['cpu_model'] = line.split(':', 1)[1].strip()
                    break
    except OSError:
        pass
    info['date'] = time.strftime('%Y-%m-%d', time.gmtime())
    info['load_average'] = [round(x, 2) for x in os.getloadavg()]
    for key, dist in (('numpy', 'numpy'), ('pinocchio', 'pin'), ('pybullet', 'pybullet')):
        try:
            info[key] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            info[key] = 'missing'
    return info


def met(key, value):
    """True when `value` meets the target of `key` (which has one)."""
    op, bound = TARGETS[key]
    return {'<=': value <= bound, '>=': value >= bound, '<': value < bound}[op]


def verdict(key, value, results=None):
    """'met (op bound)' / 'MISSED (op bound)' for a key with a target, '' otherwise; with `results`, what
    the ratio is made of follows (BESIDE)."""
    if key not in TARGETS:
        return ''
    op, bound = TARGETS[key]
    text = f'{"met" if met(key, value) else "MISSED"} ({op} {bound:g})'
    try:
        return text + (f': {BESIDE[key].format_map(results)}' if results is not None and key in BESIDE else '')
    except KeyError:              # a part of the ratio not measured in this run
        return text


def summary(results):
    """The verdict in words: which targets of the results are met, which are missed (with their values)."""
    keys = [k for k in results if k in TARGETS]
    missed = [f"{k} = {results[k]:.4g} ({TARGETS[k][0]} {TARGETS[k][1]:g})" for k in keys if not met(k, results[k])]
    lines = [f'Targets met: {len(keys) - len(missed)} of {len(keys)}: '
             + (', '.join(k for k in keys if met(k, results[k])) or 'none') + '.']
    if missed:
        lines.append('Targets MISSED: ' + ', '.join(missed) + '.')
    floor = results.get('realtime_floor_1khz_deadline_hit_ratio')
    if floor is not None and floor < QUIET_FLOOR:
        lines.append(f'Caution: the floor of B3 (no physics, no law) answered only {100 * floor:.1f} % of its periods '
                     f'in time (under {100 * QUIET_FLOOR:g} %): on this machine, under its load in this run, the '
                     'transport alone misses periods, so B3\'s absolute figures (latency, real-time factor, hit '
                     'ratio) say as much about the machine as about the loop; missed_vs_floor compares the loop with '
                     'the floor in the same run.')
    return lines


def table(results):
    """The results as aligned text lines: metric, value, target verdict; then the summary."""
    width = max(len(k) for k in results)
    rows = [f'{k:<{width}}  {v:>12.4g}  {verdict(k, v, results)}'.rstrip() for k, v in results.items()]
    return rows + [''] + summary(results)


def markdown(results, machine, quick, parts=None):
    """The results as a markdown table headed by the machine (and `parts`, the parts run, when not all of PARTS;
    None: all), for the docs."""
    load = machine.get('load_average')
    which = '' if parts is None or sorted(parts) == sorted(PARTS) else f' (parts {", ".join(p.upper() for p in parts)} only)'
    head = (f'{"Quick" if quick else "Full"} run of `make bench`{which} on {machine.get("date", "an unknown date")}, '
            f'{machine["cpu_model"]}, {machine["cores"]} cores, Python {machine["python"]}, '
            f'Pinocchio {machine["pinocchio"]}, PyBullet {machine["pybullet"]}'
            + (f'; load average {load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f} at the end (1 / 5 / 15 min)'
               if load else '')
            + ('' if 'cpu_wakeup_latency_us' not in machine else
               '; B3 with no CPU wake-up latency request' if machine['cpu_wakeup_latency_us'] is None else
               f'; B3 with a CPU wake-up latency request of {machine["cpu_wakeup_latency_us"]} us held')
            + '.')
    rows = [f'| `{k}` | {v:.4g} | {verdict(k, v, results)} |' for k, v in results.items()]
    return '\n'.join([head, '', '| metric | value | target |', '|---|---:|---|', *rows, '', *summary(results)]) + '\n'


def write_json(path, obj):
    os.makedirs(os.path.dirname(path) or '.', exist_ok=True)
    tmp = path + '.tmp'
    with open(tmp, 'w', encoding='utf-8') as f:
        json.dump(obj, f, indent=2, sort_keys=False)
        f.write('\n')
    os.replace(tmp, path)


def check_finite(results):
    bad = sorted(k for k, v in results.items() if not (isinstance(v, (int, float)) and math.isfinite(v)))
    if bad:
        raise RuntimeError(f'results: non-finite values for {bad}')


# -- main ----------------------------------------------------------------------------------------
PARTS = ('b1', 'b4', 'b2', 'b3', 'b5')


def parse_args(argv):
    parser = argparse.ArgumentParser(prog='python -m benchmarks.bench', description=__doc__.split('\n')[0])
    parser.add_argument('--quick', action='store_true', help='short run (seconds), still writes every key')
    parser.add_argument('--out', default=os.path.join('out', 'bench'), help='output directory')
    parser.add_argument('--only', default=','.join(PARTS), help='comma-separated subset of b1,b2,b3,b4,b5')
    parser.add_argument('--cpu-wakeup-latency', default='0', metavar='US|none',
                        help='B3: hold a CPU wake-up latency request of US microseconds (default 0, as '
                             'cyclictest does; none: no request)')
    parser.add_argument('--domain-id', type=int, default=None,
                        help='ROS_DOMAIN_ID for the DDS parts (default: the first free of 101, 100, ..., 1)')
    args = parser.parse_args(argv)
    args.only = [p.strip() for p in args.only.split(',') if p.strip()]
    text = args.cpu_wakeup_latency
    args.cpu_wakeup_latency = None if text == 'none' else int(text) if text.isdigit() else -1
    if args.cpu_wakeup_latency == -1:
        parser.error(f'--cpu-wakeup-latency: expected a whole number of microseconds >= 0 or none, got {text!r}')
    unknown = sorted(set(args.only) - set(PARTS))
    if unknown:
        parser.error(f'--only: unknown parts {unknown}; expected some of {list(PARTS)}')
    return args


@contextlib.contextmanager
def wakeup_bound(us, log, setup):
    """B3 runs as a realtime setup runs and as cyclictest measures: with a CPU wake-up latency request of `us`
    microseconds held (None: none) for the floors and the loops alike (robot_control.ros.wakeup; the request binds
    every process, as the nodes' --cpu-wakeup-latency does). setup['cpu_wakeup_latency_us'] is the bound held,
    None when none is (not asked, or the device not writable: logged)."""
    try:
        request = None if us is None else wakeup.request(us)
    except OSError as exc:
        log(f'B3: no CPU wake-up latency request held ({wakeup.PATH}: {exc.strerror})')
        request = None
    setup['cpu_wakeup_latency_us'] = None if request is None else us
    try:
        yield
    finally:
        if request is not None:
            os.close(request)


def run(parts, plan, domain_id, log, outdir, wakeup_us=0, setup=None):
    """The metrics of `parts`, in table order; `setup` (a dict) gets how B3 ran (wakeup_bound)."""
    setup = {} if setup is None else setup
    results = {}
    if 'b1' in parts:
        log('B1 control-law cost ...')
        results.update(bench_laws(plan))
        results.update(bench_transport(plan))
    if 'b4' in parts:
        log('B4 world without ROS ...')
        results.update(bench_world(plan))
    if 'b2' in parts or 'b3' in parts:
        from benchmarks import bench_ros
        env = bench_ros.ros_env(domain_id)
        if 'b2' in parts:
            log(f'B2 lockstep over DDS (domain {env["ROS_DOMAIN_ID"]}) ...')
            results.update(bench_ros.bench_lockstep(plan, env, log, os.path.join(outdir, 'logs')))
        if 'b3' in parts:
            with wakeup_bound(wakeup_us, log, setup):
                log(f'B3 real time at 1 kHz for {plan.realtime_s:g} s per scenario ...')
                results.update(bench_ros.bench_realtime(plan, env, log, os.path.join(outdir, 'logs')))
    if 'b5' in parts:
        from benchmarks.bench_sweep import bench_sweep
        log('B5 sweep throughput ...')
        results.update(bench_sweep(plan, log))
    return results


def _exit_on_sigterm(signum, frame):
    raise SystemExit(128 + signum)


def main(argv=None):
    args = parse_args(sys.argv[1:] if argv is None else argv)
    plan = QUICK if args.quick else FULL

    def log(msg):
        print(msg, file=sys.stderr, flush=True)

    signal.signal(signal.SIGTERM, _exit_on_sigterm)     # unwinds: child processes are stopped
    claim = processes.private_domain() if args.domain_id is None else None
    try:
        domain_id = args.domain_id if claim is None else claim.acquire()
        setup = {}
        results = run(args.only, plan, domain_id, log, args.out, args.cpu_wakeup_latency, setup)
    except KeyboardInterrupt:
        log('interrupted: child processes stopped, nothing written')
        return 130
    finally:
        if claim is not None:
            claim.release()
    check_finite(results)
    machine = {**machine_info(), **setup}
    write_json(os.path.join(args.out, 'results.json'), results)
    write_json(os.path.join(args.out, 'machine.json'), {**machine, 'quick': args.quick})
    with open(os.path.join(args.out, 'results.md'), 'w', encoding='utf-8') as f:
        f.write(markdown(results, machine, args.quick, args.only))
    print(f'robot_control benchmarks{" (quick)" if args.quick else ""} on {machine["cpu_model"]}, '
          f'{machine["cores"]} cores')
    print('\n'.join(table(results)))
    print(f'written: {os.path.join(args.out, "results.json")}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
