"""Regenerate the parameter tables of docs/parameters.md from the nodes' own parameter tables.

    python -m dev.docs_params [--check] [PAGE]          # from the repository root; PAGE: docs/parameters.md

The tables sit between `<!-- params:NODE:begin -->` and `<!-- params:NODE:end -->` markers;
`--check` exits 1 when the page differs from the code (test/tools/test_docs.py runs it). Defaults are
those of the polar_two_link scenario (rows of its own show their own default).
"""
import argparse
import re
import sys
from pathlib import Path

from robot_control import param_table
from robot_control.ros import controller_params
from sim_bridge import bridge_params

#: node -> its parameter table
TABLES = {'controller': controller_params.TABLE, 'sim_bridge': bridge_params.TABLE}
SEED = {'scenario': 'polar_two_link'}
PAGE = Path(__file__).resolve().parents[1] / 'docs' / 'parameters.md'


def rows(node):
    """(parameter, type, default, meaning, bounds, set at run time) rows of `node`'s table."""
    return TABLES[node].markdown_rows(**SEED)


def render(text):
    """`text` with every parameter table replaced by the one generated from the code."""
    for node in TABLES:
        pattern = re.compile(rf'(<!-- params:{node}:begin -->\n).*?(<!-- params:{node}:end -->)', re.S)
        if not pattern.search(text):
            raise ValueError(f'parameters page: no <!-- params:{node}:begin/end --> markers')
        text = pattern.sub(lambda m: m.group(1) + param_table.markdown(rows(node)) + m.group(2), text)
    return text


def main(argv=None):
    ap = argparse.ArgumentParser(prog='python -m dev.docs_params', description=__doc__.splitlines()[0])
    ap.add_argument('page', nargs='?', default=str(PAGE))
    ap.add_argument('--check', action='store_true', help='exit 1 if the page is out of date')
    args = ap.parse_args(argv)
    with open(args.page, encoding='utf-8') as f:
        old = f.read()
    new = render(old)
    if args.check:
        if new != old:
            print(f'{args.page}: parameter tables are out of date; run python -m dev.docs_params', file=sys.stderr)
            return 1
        return 0
    with open(args.page, 'w', encoding='utf-8') as f:
        f.write(new)
    return 0


if __name__ == '__main__':
    sys.exit(main())
