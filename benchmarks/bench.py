"""Benchmarks: control-law cost, closed-loop rate and latency over DDS, physics rate, against targets.

    python -m benchmarks.bench [--quick] [--out out/bench] [--only b1,b2,b3,b4] [--domain-id N]

Writes <out>/results.json (flat: metric name -> number), <out>/machine.json (CPU, cores, versions),
<out>/results.md (the table for the README) and prints the table; child process logs go to
<out>/logs/. Every figure is a median over repeated runs after a warm-up; every ratio is
taken between figures measured side by side in the same run (B1 interleaves its cases round by
round, B2 interleaves ping-pong, polar and iiwa runs).

B1 law cost per call, us (median, p99): 2-DOF closed-form computed torque, 7-DOF iiwa computed
   torque, operational-space hybrid and Cartesian impedance (pose task space) through Pinocchio, the peer modern_robotics.ComputedTorque
   on the same iiwa and inputs (torques checked equal within 1e-8), the floor pinocchio.rnea (the iiwa's
   inverse dynamics). The targets are on each law's median over rnea's median of the same run (law_vs_rnea_*).
B2 lockstep closed loop over DDS (benchmarks.bench_ros), against a bare rclpy ping-pong; also
   the CPU time of both processes per step, which the other load of a shared machine hardly moves.
B3 real time at 1 kHz (benchmarks.bench_ros): the polar arm, the iiwa under computed torque,
   hybrid control on the table and Cartesian impedance, each after a run of the floor (the bare exchange
   of states and commands at 1 kHz without physics and law); the targets hold for each run: missed
   periods against the floor's, p99 latency, real-time factor.
B4 the PyBullet World of the iiwa without ROS: physics steps per second under torque control.

`make bench` runs it (`make bench QUICK=1` with --quick). --quick runs seconds instead of minutes
and still writes every key. ROS processes run with
ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST on a domain id private to this run (the first free of 101, 100, ..., 1).
"""
import argparse
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

from benchmarks.bench_ros import REALTIME_RUNS
from robot_control.tools import processes

#: B1's laws: case -> key stem of their figures
LAWS = {'ct_2dof': 'law_us_ct_2dof', 'ct_7dof': 'law_us_ct_7dof', 'hybrid_7dof': 'law_us_hybrid_7dof',
        'impedance_7dof': 'law_us_impedance_7dof'}
#: the targets: key -> (comparison, bound); the table marks each figure met or MISSED. Ratios of figures of
#: the same run wherever the figure depends on the machine; latency and real-time factor are the loop's
#: own requirements at 1 kHz.
TARGETS = {
    'law_vs_rnea_ct_2dof': ('<=', 8.0),
    'law_vs_rnea_ct_7dof': ('<=', 8.0),
    'law_vs_rnea_hybrid_7dof': ('<=', 30.0),
    'law_vs_rnea_impedance_7dof': ('<=', 30.0),
    'speedup_vs_modern_robotics': ('>=', 20.0),
    'lockstep_vs_pingpong_ratio': ('>=', 0.8),
    'realtime_missed_vs_floor': ('<=', 1.5),
    'realtime_latency_p99_ms': ('<=', 1.0),
    'realtime_rtf': ('>=', 0.99),
}
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
               f'{{realtime_periods_{_run}:.0f}} periods missed, floor {{realtime_floor_missed_periods:.0f}} of '
               '{realtime_floor_periods:.0f}' for _run in REALTIME_RUNS})
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
    realtime_s: float        # B3 measured duration per scenario


FULL = Plan(law_rounds=10, law_calls=400, mr_calls=10, world_rounds=7, world_steps=2000,
            dds_rounds=5, dds_warmup_s=1.0, dds_window_s=3.0, realtime_s=20.0)
QUICK = Plan(law_rounds=3, law_calls=100, mr_calls=2, world_rounds=3, world_steps=300,
             dds_rounds=1, dds_warmup_s=0.3, dds_window_s=1.0, realtime_s=2.0)


# -- statistics ----------------------------------------------------------------------------------
def median_p99_us(ns):
    """(median, 99th percentile) of durations in ns, as microseconds."""
    a = np.asarray(ns, dtype=float) / 1e3
    return float(np.median(a)), float(np.percentile(a, 99))


def time_calls(fn, inputs, out):
    """Call fn(*args) for each args in `inputs`, appending each call's wall time (ns) to `out`."""
    clock = time.perf_counter_ns
    for args in inputs:
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


def law_cases(count):
    """{name: (fn, inputs)} of B1, built on the same iiwa model and inputs; checks MR equality."""
    import modern_robotics as mr
    import pinocchio as pin

    from benchmarks.bench_mr import mr_chain
    from robot_control.gains import ServoGains
    from robot_control.laws import computed_torque, hybrid, impedance
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
    return {'ct_2dof': (computed_torque, ct2), 'ct_7dof': (computed_torque, ct7),
            'hybrid_7dof': (hybrid, hybrid_inputs(iiwa, states)),
            'impedance_7dof': (impedance, impedance_inputs(for_scenario('iiwa', task_space='pose'), states)),
            'mr_ct_7dof': (mr.ComputedTorque, mr_in), 'pin_rnea': (pin.rnea, rnea)}


def hybrid_inputs(iiwa, states):
    """Arguments of laws.hybrid for the iiwa scenario (force on z against the table, posture q_d)."""
    from robot_control.gains import ServoGains
    axes = np.array([False, False, True])
    gains_T, gains_N = ServoGains.uniform(3, KP, KV), ServoGains.uniform(3, KP, KV)
    out = []
    for q, qd, q_d, qd_d, qdd_d, _ in states:
        x = iiwa.fk(q) + 0.01
        f = np.array([0.0, 0.0, -8.0])
        out.append((iiwa, q, qd, x, qd_d[:3], qdd_d[:3], np.array([0.0, 0.0, -10.0]), np.zeros(3), np.zeros(3),
                    f, np.zeros(3), axes, 20000.0, gains_T, gains_N, q_d))
    return out


#: stiffness of the impedance case: x, y, z N/m, rx, ry, rz N m/rad
STIFFNESS = (1000.0, 1000.0, 1000.0, 100.0, 100.0, 100.0)


def impedance_inputs(model, states):
    """Arguments of laws.impedance for the iiwa in the pose task space: the target the pose at q_d moving
    with J qd_d, J qdd_d; designed damping (ratio 1); the posture q_d."""
    out = []
    for q, qd, q_d, qd_d, qdd_d, _ in states:
        J = model.J(q_d)
        out.append((model, q, qd, model.fk(q_d), J @ qd_d, J @ qdd_d, STIFFNESS, 1.0, None, None, q_d))
    return out


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
            time_calls(fn, calls, times[name] if r else [])
    stats = {name: median_p99_us(ns) for name, ns in times.items()}
    rnea = stats['pin_rnea'][0]
    out = {}
    for name, key in LAWS.items():
        out[f'{key}_median'], out[f'{key}_p99'] = stats[name]
        out[f'law_vs_rnea_{name}'] = vs_rnea(stats[name][0], rnea)
    for name, key in (('mr_ct_7dof', 'mr_ct_7dof_us'), ('pin_rnea', 'pin_rnea_us')):
        out[f'{key}_median'], out[f'{key}_p99'] = stats[name]
    out['speedup_vs_modern_robotics'] = out['mr_ct_7dof_us_median'] / out['law_us_ct_7dof_median']
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
    """B4: iiwa World physics steps per second (set_torque, step, state per step)."""
    from robot_control.models import for_scenario
    from sim_bridge.world import World

    world = World('iiwa')
    try:
        q0 = world.state()[0]
        tau = for_scenario('iiwa').g(q0)          # gravity hold: the arm stays where it starts
        rates = []
        for r in range(plan.world_rounds + 1):
            t0 = time.perf_counter_ns()
            for _ in range(plan.world_steps):
                world.set_torque(tau)
                world.step()
                world.state()
            if r:
                rates.append(plan.world_steps * 1e9 / (time.perf_counter_ns() - t0))
    finally:
        world.close()
    return {'sim_steps_per_s_iiwa': float(np.median(rates))}


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


def markdown(results, machine, quick):
    """The results as a markdown table headed by the machine, for the README."""
    load = machine.get('load_average')
    head = (f'{"Quick" if quick else "Full"} run of `make bench` on {machine.get("date", "an unknown date")}, '
            f'{machine["cpu_model"]}, {machine["cores"]} cores, Python {machine["python"]}, '
            f'Pinocchio {machine["pinocchio"]}, PyBullet {machine["pybullet"]}'
            + (f'; load average {load[0]:.2f} / {load[1]:.2f} / {load[2]:.2f} at the end (1 / 5 / 15 min).'
               if load else '.'))
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
PARTS = ('b1', 'b4', 'b2', 'b3')


def parse_args(argv):
    parser = argparse.ArgumentParser(prog='python -m benchmarks.bench', description=__doc__.split('\n')[0])
    parser.add_argument('--quick', action='store_true', help='short run (seconds), still writes every key')
    parser.add_argument('--out', default=os.path.join('out', 'bench'), help='output directory')
    parser.add_argument('--only', default=','.join(PARTS), help='comma-separated subset of b1,b2,b3,b4')
    parser.add_argument('--domain-id', type=int, default=None,
                        help='ROS_DOMAIN_ID for the DDS parts (default: the first free of 101, 100, ..., 1)')
    args = parser.parse_args(argv)
    args.only = [p.strip() for p in args.only.split(',') if p.strip()]
    unknown = sorted(set(args.only) - set(PARTS))
    if unknown:
        parser.error(f'--only: unknown parts {unknown}; expected some of {list(PARTS)}')
    return args


def run(parts, plan, domain_id, log, outdir):
    """The metrics of `parts`, in table order."""
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
            log(f'B3 real time at 1 kHz for {plan.realtime_s:g} s per scenario ...')
            results.update(bench_ros.bench_realtime(plan, env, log, os.path.join(outdir, 'logs')))
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
        results = run(args.only, plan, domain_id, log, args.out)
    except KeyboardInterrupt:
        log('interrupted: child processes stopped, nothing written')
        return 130
    finally:
        if claim is not None:
            claim.release()
    check_finite(results)
    machine = machine_info()
    write_json(os.path.join(args.out, 'results.json'), results)
    write_json(os.path.join(args.out, 'machine.json'), {**machine, 'quick': args.quick})
    with open(os.path.join(args.out, 'results.md'), 'w', encoding='utf-8') as f:
        f.write(markdown(results, machine, args.quick))
    print(f'robot_control benchmarks{" (quick)" if args.quick else ""} on {machine["cpu_model"]}, '
          f'{machine["cores"]} cores')
    print('\n'.join(table(results)))
    print(f'written: {os.path.join(args.out, "results.json")}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
