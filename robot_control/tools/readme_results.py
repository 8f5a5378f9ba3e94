"""Regenerate the README's results and benchmark tables from the files the tools wrote (never typed by hand).

    python -m robot_control.tools.readme_results [--readme README.md] [--results out/demo] [--bench out/bench]
                                                 [--robustness out/robustness/summary.json]
                                                 [--two-hosts out/two_hosts/figures.json] [--check]

Reads every `<results>/*/summary.json` written by `python -m robot_control.demo` (run
`python -m robot_control.demo --all` to produce one per experiment) and replaces what lies
between the lines `<!-- results:begin -->` and `<!-- results:end -->` in the README with a
markdown table, one row per experiment: its key metrics in SI units. Nothing outside the markers
changes; a README without both markers is an error. When `<bench>/results.md` exists (written
by `make bench`) and the README has the lines `<!-- bench:begin -->` and `<!-- bench:end -->`,
what lies between them is replaced by that table the same way; likewise the robustness table
(`<!-- robustness:begin -->`) from `out/robustness/summary.json` of a whole run of
test/e2e/test_robustness.py (a partial run is an error naming the missing figures), and the two-host
table (`<!-- two-hosts:begin -->`) from `out/two_hosts/figures.json` of a whole, passing run of
test/e2e/test_two_hosts.py. The command line leaves a table whose figures are partial as it is and
says so.
`--check` changes nothing and exits 1 when the README is not up to date (for CI).
"""
import argparse
import json
import math
import sys
from pathlib import Path

BEGIN = '<!-- results:begin -->'
END = '<!-- results:end -->'
BENCH_BEGIN = '<!-- bench:begin -->'
BENCH_END = '<!-- bench:end -->'
ROBUSTNESS_BEGIN = '<!-- robustness:begin -->'
ROBUSTNESS_END = '<!-- robustness:end -->'
TWO_HOSTS_BEGIN = '<!-- two-hosts:begin -->'
TWO_HOSTS_END = '<!-- two-hosts:end -->'
#: the figures of test/e2e/test_two_hosts.py the README table needs
TWO_HOSTS_FIGURES = (
    'realtime_packets_per_s_a_to_b', 'realtime_packets_per_s_b_to_a', 'realtime_outage_longest_joint_states_gap_ms',
    'realtime_outage_sim_s_per_wall_s', 'realtime_outage_longest_publish_ms_bridge',
    'realtime_outage_longest_publish_ms_controller', 'lockstep_outage_longest_publish_ms_bridge',
    'lockstep_outage_longest_publish_ms_controller', 'realtime_outage_brakes_command_age_ms',
    'realtime_outage_controller_error_after_s', 'realtime_outage_commands_resume_after_s',
    'lockstep_outage_resume_after_s', 'realtime_outage_resume_torque_minus_gravity_hold',
    'realtime_outage_rss_growth_mb_bridge', 'realtime_outage_rss_growth_mb_controller',
    'lockstep_outage_republished_states', 'lockstep_bit_identical_ticks_states',
    'lockstep_bit_identical_ticks_commands', 'lockstep_static_peers_packets_a_to_b',
    'lockstep_static_peers_multicast_packets', 'realtime_subnet_multicast_packets', 'tests_failed')
#: the figures of test/e2e/test_robustness.py a README table needs (a partial run lacks some)
ROBUSTNESS_FIGURES = ('1_controller_sigkill', '2_bridge_sigkill', '4_flood', '6_second_publisher_robot_joint_commands',
                      '6_second_publisher_effort_controller/commands', '7_unguarded', '7_lost_contact_processes',
                      '8_library_computed_torque', '8_library_independent_joint', '8_saturated_step_processes',
                      '8_without_anti_windup')
REQUIRED = ('scenario', 'mode', 'duration_s', 'samples', 'rms_error', 'max_error', 'final_error',
            'steady_state_error', 'settling_time_s', 'force_rms_error', 'saturated_ticks', 'loop_rate_hz',
            'latency_p50_ms', 'latency_p99_ms')
MAX_LISTED = 3   # coordinates listed one by one in a cell; more: the largest only
COLUMNS = ('experiment', 'scenario', 'law', 'mode', 'sim time', 'RMS error', 'max error', 'steady-state error',
           'settling time', 'force RMS error', 'saturated ticks', 'loop rate', 'latency p50 / p99', 'figures')
#: unit suffixes of the names of an experiment's own figures (summary 'figures'); a name without one is a ratio
FIGURE_UNITS = ('m', 'rad', 's', 'N')


def number(x, unit=''):
    """A compact number with its unit; '-' for None/NaN."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return '-'
    if isinstance(x, bool) or isinstance(x, int):
        text = str(x)
    elif x == 0.0:
        text = '0'
    elif 1e-2 <= abs(x) < 1e4:
        text = f'{x:.3g}'
    else:
        text = f'{x:.2e}'
    return f'{text} {unit}'.strip()


def per_coordinate(values, units=None, unit=''):
    """'theta1 1.2e-03 rad, r 4.0e-04 m' from {name: value}; '-' when empty or absent."""
    if values is None:
        return '-'
    if not isinstance(values, dict):
        return number(values, unit)
    units = units or {}
    if len(values) > MAX_LISTED:   # e.g. 7 joints: the largest magnitude and where
        finite = {k: v for k, v in values.items() if v is not None}
        if not finite:
            return '-'
        name = max(finite, key=lambda k: abs(finite[k]))
        return f'max {number(finite[name], unit or units.get(name, ""))} ({name})'
    parts = [f'{name} {number(v, unit or units.get(name, ""))}' for name, v in values.items()]
    return ', '.join(parts) if parts else '-'


def figures(values):
    """'push deflection -0.01 m, push return overshoot 0' from an experiment's own figures {name_unit: value}."""
    parts = []
    for name, value in (values or {}).items():
        label, _, unit = name.rpartition('_')
        if unit not in FIGURE_UNITS:
            label, unit = name, ''
        parts.append(f'{label.replace("_", " ")} {number(value, unit)}')
    return ', '.join(parts) if parts else '-'


def load_summaries(results_dir):
    """[(name, summary)] of results_dir/*/summary.json, sorted by the demo's experiment order then name."""
    results_dir = Path(results_dir)
    found = []
    for path in sorted(results_dir.glob('*/summary.json')):
        try:
            summary = json.loads(path.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise ValueError(f'{path}: not a readable summary ({exc})') from None
        missing = [k for k in REQUIRED if k not in summary]
        if missing:
            raise ValueError(f'{path}: missing keys {missing}')
        found.append((path.parent.name, summary))
    try:
        from robot_control.tools.demo_experiments import EXPERIMENTS
        order = {name: i for i, name in enumerate(EXPERIMENTS)}
    except ImportError:  # pragma: no cover - the package is importable wherever this runs
        order = {}

    def key(item):
        name, summary = item
        exp = summary.get('experiment', name)
        return (order.get(exp, len(order)), name)
    return sorted(found, key=key)


def row(name, s):
    units = s.get('units', {})
    exp = s.get('experiment') or name
    label = exp if exp == name else f'{exp} ({name})'
    force = per_coordinate(s.get('force_rms_error'), unit='N') if s.get('force_rms_error') else '-'
    latency = '-'
    if s.get('latency_p50_ms') is not None:
        latency = f'{number(s["latency_p50_ms"])} / {number(s.get("latency_p99_ms"))} ms'
    cells = (label, s['scenario'], s.get('law', '-'), s['mode'], number(s['duration_s'], 's'),
             per_coordinate(s['rms_error'], units), per_coordinate(s['max_error'], units),
             per_coordinate(s['steady_state_error'], units), number(s['settling_time_s'], 's'),
             force, number(s['saturated_ticks']), number(s['loop_rate_hz'], 'Hz'), latency, figures(s.get('figures')))
    return '| ' + ' | '.join(str(c).replace('|', '\\|') for c in cells) + ' |'


def table(summaries):
    """The markdown between the markers (without them)."""
    lines = ['', '_Generated by `python -m robot_control.tools.readme_results` from `out/demo/*/summary.json` '
                 '(`python -m robot_control.demo --all`); do not edit by hand._', '']
    if not summaries:
        lines += ['No results yet: run `python -m robot_control.demo --all`.', '']
        return '\n'.join(lines)
    lines.append('| ' + ' | '.join(COLUMNS) + ' |')
    lines.append('|' + '---|' * len(COLUMNS))
    lines += [row(name, s) for name, s in summaries]
    lines.append('')
    return '\n'.join(lines)


def bench_table(bench_dir):
    """The markdown between the bench markers: `<bench_dir>/results.md`; None when there is none."""
    path = Path(bench_dir) / 'results.md'
    if not path.is_file():
        return None
    return '\n'.join(['', '_Generated by `python -m robot_control.tools.readme_results` from `out/bench/results.md` '
                            '(`make bench`); do not edit by hand._', '', path.read_text().strip('\n'), ''])


def robustness_table(summary):
    """The markdown between the robustness markers, from out/robustness/summary.json (a dict).

    ValueError naming what is missing when the summary is not of a whole run of test_robustness.py."""
    fig = summary.get('figures', {})
    missing = [k for k in ROBUSTNESS_FIGURES if k not in fig]
    if missing or 'bad_inputs_per_topic' not in summary:
        raise ValueError(f'robustness summary of a partial run (missing {missing or ["bad_inputs_per_topic"]}); '
                         'run the whole test/e2e/test_robustness.py')
    per_topic = summary['bad_inputs_per_topic']
    counts = sorted(set(per_topic.values()))
    tried = (f'{counts[0]:,} each, {summary["bad_inputs_total"]:,} in all ({", ".join(sorted(per_topic))})'
             if len(counts) == 1 else ', '.join(f'{k} {v:,}' for k, v in sorted(per_topic.items())))
    kill, bridge, flood = fig['1_controller_sigkill'], fig['2_bridge_sigkill'], fig['4_flood']
    rogue = [fig['6_second_publisher_robot_joint_commands'], fig['6_second_publisher_effort_controller/commands']]
    detect = sorted(r['detected_after_s'] * 1e3 for r in rogue)
    saturation = max(fig['8_library_computed_torque']['worst_excess_overshoot'],
                     fig['8_library_independent_joint']['worst_excess_overshoot'],
                     *(a - b for a, b in zip(fig['8_saturated_step_processes']['overshoot_saturated'],
                                             fig['8_saturated_step_processes']['overshoot_unsaturated'])))
    rows = [
        ('faults injected / survived', f'{summary["faults_survived"]} / {summary["faults_injected"]}'),
        ('bad inputs tried (generated with hypothesis: in-process and replayed to the processes)', tried),
        ('efforts checked (finite, within limits)', f'{summary["efforts_checked"]:,}'),
        ('unsafe commands published', f'**{summary["unsafe_commands_published"]}**'),
        ('controller killed mid-motion: brakes engaged after the last command / end-effector drift braked',
         f'{kill["brake_after_last_command_s"]:.3f} s of simulated time (command_timeout 0.05 s) / '
         f'{kill["drift_with_brakes_m"] * 1e3:.1f} mm'),
        ('bridge killed: controller ERROR on /diagnostics after',
         f'{bridge["watchdog_error_after_s"]:.2f} s (state_timeout 0.5 s); resumes from the current state'),
        (f'joint_states flood at {flood["publisher_rate_hz"]:,} Hz for 5 s: controller RSS growth / answer age p99',
         f'{flood["rss_growth_mb"]:.1f} MB / {flood["answer_age_p99_ms"]:.1f} ms'),
        ('second command publisher (the controller stopped for 0.3 s meanwhile): detected after / rogue efforts '
         'applied',
         f'{detect[0]:.0f}-{detect[-1]:.0f} ms / {sum(r["rogue_efforts_applied"] for r in rogue)} of '
         f'{sum(r["rogue_messages_sent"] for r in rogue)}'),
        ('lost contact in hybrid control: travel past the surface (guard at 10 mm) / unguarded',
         f'{fig["7_lost_contact_processes"]["max_beyond_surface_m"] * 1e3:.1f} mm, with ERROR / '
         f'{fig["7_unguarded"]["travel_m"] * 1e3:.0f} mm'),
        ('saturated steps with anti-windup: overshoot beyond the unsaturated response / without anti-windup',
         f'<= {saturation:.1%} / {max(fig["8_without_anti_windup"]["overshoot"]):.0%}'),
    ]
    lines = ['', '_Generated by `python -m robot_control.tools.readme_results` from `out/robustness/summary.json` '
                 '(`pytest test/e2e/test_robustness.py`); do not edit by hand._', '', '| figure | value |', '|---|---|']
    lines += [f'| {a} | {b} |' for a, b in rows]
    return '\n'.join(lines + [''])


def two_hosts_table(fig):
    """The markdown between the two-host markers, from out/two_hosts/figures.json (a dict).

    ValueError naming what is missing when the figures are not of a whole run of test_two_hosts.py, or
    how many tests failed."""
    missing = [k for k in TWO_HOSTS_FIGURES if k not in fig]
    if missing:
        raise ValueError(f'two-host figures of a partial run (missing {missing}); run the whole '
                         'test/e2e/test_two_hosts.py')
    if fig['tests_failed']:
        raise ValueError(f'two-host figures of a run in which {fig["tests_failed"]} tests failed')
    multicast = (f'{fig["lockstep_static_peers_multicast_packets"]} (the SUBNET run: '
                 f'{fig["realtime_subnet_multicast_packets"]})')
    f = fig

    def pair(a, b, spec, unit):
        return f'{f[a]:{spec}} / {f[b]:{spec}} {unit}'.strip()

    rt, ls = 'realtime_outage_', 'lockstep_outage_'
    rows = [
        ('packets per second on the link, each way (realtime, SUBNET discovery)',
         pair('realtime_packets_per_s_a_to_b', 'realtime_packets_per_s_b_to_a', ',', ''), '> 500'),
        ('failure: longest gap in joint_states on the bridge\'s computer',
         f'{f[rt + "longest_joint_states_gap_ms"]:.1f} ms', '< 50 ms'),
        ('failure: simulated time per wall-clock second', f'{f[rt + "sim_s_per_wall_s"]:.3f}', '1 +- 5 %'),
        ('failure: longest publish call, bridge / controller, realtime; lockstep',
         pair(rt + 'longest_publish_ms_bridge', rt + 'longest_publish_ms_controller', '.2f', 'ms') + '; '
         + pair(ls + 'longest_publish_ms_bridge', ls + 'longest_publish_ms_controller', '.2f', 'ms'), '< 20 ms'),
        ('failure: brakes engaged, age of the last valid command (simulated time)',
         f'{f[rt + "brakes_command_age_ms"]:.1f} ms', 'command_timeout 50 ms + 2 ticks'),
        ('failure: controller\'s watchdog ERROR after the link went down',
         f'{f[rt + "controller_error_after_s"]:.2f} s', 'state_timeout 0.5 s + 0.3 s'),
        ('failure: commands resume after the link\'s return, realtime / lockstep',
         pair(rt + 'commands_resume_after_s', ls + 'resume_after_s', '.2f', 's'), '< 1 s'),
        ('failure: applied torque minus the gravity hold, first second after the return',
         f'{f[rt + "resume_torque_minus_gravity_hold"]:.2f} N m', '< 1 N m'),
        ('failure: RSS growth, bridge / controller', pair(rt + 'rss_growth_mb_bridge', rt + 'rss_growth_mb_controller',
                                                          '.1f', 'MB'), '< 10 MB'),
        ('failure, lockstep: states re-published', str(f[ls + 'republished_states']), '>= 5'),
        ('lockstep across the link against both nodes on one computer',
         f'bit-identical ({f["lockstep_bit_identical_ticks_states"]:,} states, '
         f'{f["lockstep_bit_identical_ticks_commands"]:,} commands), no tick lost', 'bit-identical'),
        ('static peers (no multicast route): packets host a to b / multicast packets on the link',
         f'{f["lockstep_static_peers_packets_a_to_b"]:,} / {multicast}', '> 500 / 0'),
    ]
    lines = ['', '_Generated by `python -m robot_control.tools.readme_results` from `out/two_hosts/figures.json` '
                 '(`pytest test/e2e/test_two_hosts.py`); do not edit by hand._', '',
             '| two hosts, link down for 1.5 s mid-move (failure) | measured | required |', '|---|---|---|']
    lines += [f'| {a} | {b} | {c} |' for a, b, c in rows]
    return '\n'.join(lines + [''])


def replace_between_markers(text, body, begin=BEGIN, end=END):
    """`text` with everything between `begin` and `end` replaced by `body`; ValueError without both markers."""
    start = text.find(begin)
    stop = text.find(end)
    if start < 0 or stop < 0 or stop < start:
        raise ValueError(f'readme: needs the markers {begin} and {end} (in this order)')
    if text.find(begin, start + 1) >= 0 or text.find(end, stop + 1) >= 0:
        raise ValueError(f'readme: the markers {begin} and {end} must appear once each')
    return text[:start + len(begin)] + '\n' + body.strip('\n') + '\n' + text[stop:]


def update(readme, results_dir, check=False, bench_dir=None, robustness=None, two_hosts=None, on_partial=None):
    """Rewrite `readme` (unless check); returns True when its content changed (or would change).

    `robustness`, `two_hosts`: the JSON files of those tables (None or a missing file: the table stays).
    Figures the table refuses (a partial run) raise ValueError, or with `on_partial` given leave that
    table as it is and call on_partial(the error's text)."""
    readme = Path(readme)
    text = readme.read_text()
    new = replace_between_markers(text, table(load_summaries(results_dir)))
    bench = None if bench_dir is None or BENCH_BEGIN not in text else bench_table(bench_dir)
    if bench is not None:
        new = replace_between_markers(new, bench, BENCH_BEGIN, BENCH_END)
    for path, make, begin, end in ((robustness, robustness_table, ROBUSTNESS_BEGIN, ROBUSTNESS_END),
                                   (two_hosts, two_hosts_table, TWO_HOSTS_BEGIN, TWO_HOSTS_END)):
        if path is None or begin not in text or not Path(path).is_file():
            continue
        try:
            body = make(json.loads(Path(path).read_text()))
        except ValueError as exc:
            if on_partial is None:
                raise
            on_partial(str(exc))
            continue
        new = replace_between_markers(new, body, begin, end)
    changed = new != text
    if changed and not check:
        readme.write_text(new)
    return changed


def main(argv=None):
    root = Path(__file__).resolve().parents[2]
    p = argparse.ArgumentParser(prog='python -m robot_control.tools.readme_results', description=__doc__.split('\n')[0])
    p.add_argument('--readme', default=str(root / 'README.md'))
    p.add_argument('--results', default=str(root / 'out' / 'demo'), help='directory holding */summary.json')
    p.add_argument('--bench', default=str(root / 'out' / 'bench'), help='directory holding results.md of make bench')
    p.add_argument('--robustness', default=str(root / 'out' / 'robustness' / 'summary.json'),
                   help='summary.json of a whole run of test/e2e/test_robustness.py')
    p.add_argument('--two-hosts', default=str(root / 'out' / 'two_hosts' / 'figures.json'),
                   help='figures.json of a whole run of test/e2e/test_two_hosts.py')
    p.add_argument('--check', action='store_true', help='exit 1 if the README is not up to date; change nothing')
    opts = p.parse_args(argv)
    def partial(message):
        print(f'readme_results: {message}: that table is left as it is', file=sys.stderr)

    try:
        changed = update(opts.readme, opts.results, check=opts.check, bench_dir=opts.bench,
                         robustness=opts.robustness, two_hosts=opts.two_hosts, on_partial=partial)
    except (OSError, ValueError) as exc:
        print(f'readme_results: {exc}', file=sys.stderr)
        return 2
    n = len(load_summaries(opts.results))
    if opts.check:
        print(f'readme_results: {opts.readme} is {"out of date" if changed else "up to date"} ({n} results)')
        return 1 if changed else 0
    print(f'readme_results: {"updated" if changed else "unchanged"} {opts.readme} ({n} results)')
    return 0


if __name__ == '__main__':
    sys.exit(main())
