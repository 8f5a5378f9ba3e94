"""The README's parameter tables are generated from the nodes' declarations and kept current."""
import os

import pytest

from robot_control.tools import readme_params

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
README = os.path.join(ROOT, 'README.md')


def test_readme_parameter_tables_match_the_code():
    assert readme_params.main(['--check', README]) == 0


def test_every_declared_parameter_has_a_row():
    text = open(README, encoding='utf-8').read()
    for node in readme_params.TABLES:
        for name, *_ in readme_params.rows(node):
            assert f'| {name} |' in text, name


def test_check_detects_a_stale_table(tmp_path):
    stale = tmp_path / 'README.md'
    stale.write_text('<!-- params:controller:begin -->\nold\n<!-- params:controller:end -->\n'
                     '<!-- params:sim_bridge:begin -->\n<!-- params:sim_bridge:end -->\n')
    assert readme_params.main(['--check', str(stale)]) == 1
    assert readme_params.main([str(stale)]) == 0
    assert readme_params.main(['--check', str(stale)]) == 0
    assert '| zeta | double | 1.0 |' in stale.read_text()


def test_missing_markers_are_named(tmp_path):
    bare = tmp_path / 'README.md'
    bare.write_text('no tables here\n')
    with pytest.raises(ValueError, match='params:controller'):
        readme_params.main([str(bare)])
