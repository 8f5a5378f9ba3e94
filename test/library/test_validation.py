"""The library's argument errors carry the argument's name as data (ArgumentError.name)."""
import numpy as np
import pytest

from robot_control import urdf, validation
from robot_control.gains import GainRuleError, design
from robot_control.models import make_model
from robot_control.trajectory import point_to_point
from robot_control.validation import ArgumentError


@pytest.mark.parametrize('call, name', [
    (lambda: validation.vector('q', [1.0, float('nan')], 2), 'q'),
    (lambda: validation.scalar('dt', 'x'), 'dt'),
    (lambda: validation.names('joints', ['a', 'a']), 'joints'),
    (lambda: make_model('polar_two_link', m=-1.0), 'm'),
    (lambda: point_to_point([0.0], [1.0], -1.0), 'T'),
    (lambda: urdf.resolve('no_such_robot'), 'urdf'),
    (lambda: design(zeta=0.5, omega_res=12.0), 'zeta'),
])
def test_errors_name_the_argument_as_data(call, name):
    with pytest.raises(ArgumentError) as info:
        call()
    assert info.value.name == name
    assert str(info.value) == f'{name}: {info.value.reason}'
    assert isinstance(info.value, ValueError)


def test_gain_rule_errors_keep_the_rule():
    with pytest.raises(GainRuleError) as info:
        design(zeta=0.5, omega_res=12.0)
    assert info.value.rule.startswith('zeta >= 1') and info.value.name == 'zeta'


def test_a_checked_vector_is_returned_as_is():
    q = np.array([0.1, 0.2])
    assert validation.vector('q', q, 2) is q
