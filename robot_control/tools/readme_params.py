"""Regenerate the README's parameter tables from the nodes' own declarations.

    python -m robot_control.tools.readme_params [--check] [README.md]

The tables sit between `<!-- params:NODE:begin -->` and `<!-- params:NODE:end -->` markers;
`--check` exits 1 when the README differs from the code (a test runs it).
"""
import argparse
import math
import re
import sys

from robot_control.ros import params
from sim_bridge import parameters as bridge_params

HEADER = '| parameter | type | default | meaning, units | bounds | set at run time |\n|---|---|---|---|---|---|\n'


def _value(v):
    if isinstance(v, float) and math.isinf(v):
        return '.inf'
    if isinstance(v, (list, tuple)):
        return '[' + ', '.join(_value(x) for x in v) + ']'
    if isinstance(v, str):
        return f"'{v}'"
    return str(v).lower() if isinstance(v, bool) else str(v)


def _cell(text):
    return str(text).replace('|', '\\|').replace('\n', ' ')


def controller_rows():
    """Rows for the controller node, defaults of the polar_two_link scenario for model_params.*."""
    rows = [params.scenario_spec(), params.model_spec('polar_two_link')]
    rows += params.model_param_specs('polar_two_link') + params.specs({})
    return [(s.name, s.type.name.lower(), _value(s.default), s.description, s.bounds,
             'no' if s.read_only else 'yes') for s in rows]


def bridge_rows():
    """Rows for the sim_bridge node, defaults of the polar_two_link scenario."""
    name = 'polar_two_link'
    specs = bridge_params.robot_specs() + [bridge_params.joints_spec(name)]
    specs += bridge_params.specs(name, len(bridge_params.joints_spec(name).default))
    return [(s.name, s.kind, _value(s.default), s.description, '', 'no' if s.read_only else 'yes')
            for s in specs]


def table(rows):
    return HEADER + ''.join('| ' + ' | '.join(_cell(c) for c in row) + ' |\n' for row in rows)


TABLES = {'controller': controller_rows, 'sim_bridge': bridge_rows}


def render(text):
    """`text` with every parameter table replaced by the one generated from the code."""
    for node, rows in TABLES.items():
        pattern = re.compile(rf'(<!-- params:{node}:begin -->\n).*?(<!-- params:{node}:end -->)', re.S)
        if not pattern.search(text):
            raise ValueError(f'README: no <!-- params:{node}:begin/end --> markers')
        text = pattern.sub(lambda m: m.group(1) + table(rows()) + m.group(2), text)
    return text


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument('readme', nargs='?', default='README.md')
    ap.add_argument('--check', action='store_true', help='exit 1 if the README is out of date')
    args = ap.parse_args(argv)
    with open(args.readme, encoding='utf-8') as f:
        old = f.read()
    new = render(old)
    if args.check:
        if new != old:
            print(f'{args.readme}: parameter tables are out of date; run python -m robot_control.tools.readme_params',
                  file=sys.stderr)
            return 1
        return 0
    with open(args.readme, 'w', encoding='utf-8') as f:
        f.write(new)
    return 0


if __name__ == '__main__':
    sys.exit(main())
