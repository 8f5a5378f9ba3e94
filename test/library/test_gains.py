"""Gain design against the lecture: performance specification, disturbance rejection, PID placement."""
import dataclasses
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from robot_control.gains import (RULE_RESONANCE, RULE_ZETA, Design, GainRuleError, ServoGains, design, flag,
                                 pd_steady_state_error, pid_gains)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


# -- the lecture's worked example and the PD rule --------------------------------------------------

def test_polar_robot_example_kv_12_kp_36():
    """Lecture example: zeta = 1, w_res = 12 rad/s -> w_n = 0.5 * 12 = 6, s^2 + 12 s + 36 = 0."""
    d = design(zeta=1.0, omega_res=12.0)
    assert (d.zeta, d.omega_n, d.omega_res, d.kv, d.kp, d.ki) == (1.0, 6.0, 12.0, 12.0, 36.0, 0.0)
    np.testing.assert_allclose(np.polymul([1.0, 6.0], [1.0, 6.0]), [1.0, d.kv, d.kp], rtol=0, atol=0)


@pytest.mark.parametrize('zeta, omega_n', [(1.0, 6.0), (1.5, 2.0), (3.0, 10.0), (1.0, 0.25)])
def test_pd_gains_match_the_standard_second_order_form(zeta, omega_n):
    """kp = w_n^2, kv = 2 zeta w_n; roots -zeta w_n +- w_n sqrt(zeta^2 - 1) are real and negative."""
    d = design(zeta=zeta, omega_n=omega_n)
    assert d.kp == pytest.approx(omega_n ** 2, rel=1e-15)
    assert d.kv == pytest.approx(2.0 * zeta * omega_n, rel=1e-15)
    expected = sorted([-zeta * omega_n + s * omega_n * math.sqrt(zeta ** 2 - 1.0) for s in (-1.0, 1.0)])
    roots = np.roots([1.0, d.kv, d.kp])
    assert np.all(np.abs(roots.imag) <= 1e-6 * omega_n)
    np.testing.assert_allclose(np.sort(roots.real), expected, rtol=0, atol=1e-6 * omega_n)


def test_omega_n_defaults_to_the_largest_the_resonance_rule_allows():
    assert design(omega_res=7.0).omega_n == 3.5
    assert design(omega_res=12.0, omega_n=6.0).omega_n == 6.0   # on the boundary: allowed
    assert design(omega_res=12.0, omega_n=4.0).kp == 16.0
    assert design(omega_n=5.0).omega_res is None


def test_underdamped_design_is_refused_naming_the_rule():
    with pytest.raises(GainRuleError, match='zeta >= 1') as info:
        design(zeta=0.7, omega_res=12.0)
    assert isinstance(info.value, ValueError)
    assert info.value.rule == RULE_ZETA
    assert str(info.value).startswith('zeta')


@pytest.mark.parametrize('kwargs, override', [(dict(zeta=0.7, omega_res=12.0), 'allow_underdamped'),
                                              (dict(omega_res=12.0, omega_n=6.5), 'allow_resonance')])
def test_a_refusal_names_its_override_as_the_caller_reads_it(kwargs, override):
    """The library's reader gets the keyword argument, the command line's the flag, any other reader
    (the controller node: its parameter) what its name_override makes of the keyword."""
    with pytest.raises(GainRuleError) as info:
        design(**kwargs)
    assert info.value.override == override
    assert info.value.reason.endswith(f'override: {override}=True')
    with pytest.raises(GainRuleError) as info:
        design(**kwargs, name_override=flag)
    assert info.value.reason.endswith(f'override: --{override.replace("_", "-")}') and '=True' not in str(info.value)
    with pytest.raises(GainRuleError) as info:
        design(**kwargs, name_override=lambda name: f'set {name}')
    assert info.value.reason.endswith(f'override: set {override}')
    assert design(**kwargs, **{override: True}).kp > 0.0


def test_underdamped_design_with_override_has_complex_roots():
    d = design(zeta=0.5, omega_res=12.0, allow_underdamped=True)
    assert (d.kp, d.kv) == (36.0, 6.0)
    assert np.all(np.abs(np.roots([1.0, d.kv, d.kp]).imag) > 1.0)


def test_resonance_rule_is_enforced_unless_allowed():
    with pytest.raises(GainRuleError, match=r'omega_n <= 0\.5 omega_res') as info:
        design(omega_res=12.0, omega_n=6.5)
    assert info.value.rule == RULE_RESONANCE
    d = design(omega_res=12.0, omega_n=6.5, allow_resonance=True)
    assert d.kp == 42.25 and d.kv == 13.0


@pytest.mark.parametrize('kwargs, name', [
    (dict(zeta=0.0, omega_res=12.0), 'zeta'),
    (dict(zeta=float('nan'), omega_res=12.0), 'zeta'),
    (dict(omega_res=-12.0), 'omega_res'),
    (dict(omega_res=float('inf')), 'omega_res'),
    (dict(omega_n=0.0), 'omega_n'),
    (dict(), 'omega_n'),
])
def test_bad_design_arguments_are_named(kwargs, name):
    with pytest.raises(ValueError, match=f'^{name}'):
        design(**kwargs)


# -- PID placement --------------------------------------------------------------------------------

@pytest.mark.parametrize('zeta, omega_n', [(1.0, 6.0), (1.0, 1.0), (1.2, 6.0), (2.0, 3.0), (5.0, 0.5)])
def test_pid_cubic_factors_as_designed(zeta, omega_n):
    """s^3 + kv s^2 + kp s + ki = (s^2 + 2 zeta w_n s + w_n^2)(s + w_n): same w_n, third pole at -w_n."""
    d = design(zeta=zeta, omega_n=omega_n, integral=True)
    expected = np.polymul([1.0, 2.0 * zeta * omega_n, omega_n ** 2], [1.0, omega_n])
    np.testing.assert_allclose([1.0, d.kv, d.kp, d.ki], expected, rtol=1e-15, atol=0)
    assert (d.kp, d.kv, d.ki) == pid_gains(zeta, omega_n)
    assert d.kv == pytest.approx((2 * zeta + 1) * omega_n) and d.ki == pytest.approx(omega_n ** 3)


@pytest.mark.parametrize('zeta', [1.2, 2.0, 5.0])
def test_pid_roots_are_real_and_negative(zeta):
    """Distinct roots (zeta > 1): np.roots is well conditioned, every root real and < 0."""
    d = design(zeta=zeta, omega_res=12.0, integral=True)
    roots = np.roots([1.0, d.kv, d.kp, d.ki])
    expected = sorted([-6.0, -6.0 * (zeta + math.sqrt(zeta ** 2 - 1)), -6.0 * (zeta - math.sqrt(zeta ** 2 - 1))])
    assert np.all(np.abs(roots.imag) < 1e-9)
    np.testing.assert_allclose(np.sort(roots.real), expected, rtol=1e-9)
    assert np.all(roots.real < 0.0)


def test_pid_critically_damped_is_a_triple_root_within_the_resonance_rule():
    """zeta = 1, w_res = 12: kv = 3 w_n = 18, kp = 3 w_n^2 = 108, ki = w_n^3 = 216; every pole at -6 = -0.5 w_res."""
    d = design(zeta=1.0, omega_res=12.0, integral=True)
    assert (d.kv, d.kp, d.ki) == (18.0, 108.0, 216.0)
    roots = np.roots([1.0, d.kv, d.kp, d.ki])
    # a triple root is ill-conditioned for np.roots: errors of order eps^(1/3) * w_n
    np.testing.assert_allclose(roots, -6.0, atol=1e-3)
    assert np.all(roots.real < 0.0)
    assert np.max(np.abs(roots)) <= 0.5 * 12.0 + 1e-3


# -- disturbance rejection: simulate the lecture's error equations ---------------------------------

def _rk4(f, x0, dt, steps):
    """States (steps+1, len(x0)) of x' = f(x) by classic Runge-Kutta."""
    xs = [np.asarray(x0, dtype=float)]
    for _ in range(steps):
        x = xs[-1]
        k1 = f(x)
        k2 = f(x + 0.5 * dt * k1)
        k3 = f(x + 0.5 * dt * k2)
        k4 = f(x + dt * k3)
        xs.append(x + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4))
    return np.array(xs)


def test_pd_error_under_constant_disturbance_settles_at_d_over_m_kp():
    """m (e'' + kv e' + kp e) = d, zeta = 1: e(t) = d/(m kp) (1 - (1 + w_n t) e^(-w_n t)) -> d/(m kp)."""
    m, dist = 2.0, 5.0
    g = design(zeta=1.0, omega_res=12.0)
    w = g.omega_n
    xs = _rk4(lambda x: np.array([x[1], dist / m - g.kv * x[1] - g.kp * x[0]]), [0.0, 0.0], 1e-3, 4000)
    t = np.arange(xs.shape[0]) * 1e-3
    e_ss = pd_steady_state_error(dist, m, g.kp)
    assert e_ss == pytest.approx(5.0 / 72.0, rel=1e-15)
    np.testing.assert_allclose(xs[:, 0], e_ss * (1 - (1 + w * t) * np.exp(-w * t)), atol=1e-10)
    assert xs[-1, 0] == pytest.approx(e_ss, rel=1e-8)


def test_pid_rejects_constant_disturbance_without_overshoot():
    """E(s) = d / (m (s + w_n)^3) for D = d/s: e(t) = (d/m) t^2 e^(-w_n t) / 2, never changes sign, -> 0."""
    m, dist = 2.0, 5.0
    g = design(zeta=1.0, omega_res=12.0, integral=True)
    w = g.omega_n

    def f(x):  # x = (int e, e, e')
        return np.array([x[1], x[2], dist / m - g.kv * x[2] - g.kp * x[1] - g.ki * x[0]])

    xs = _rk4(f, [0.0, 0.0, 0.0], 1e-3, 5000)
    t = np.arange(xs.shape[0]) * 1e-3
    np.testing.assert_allclose(xs[:, 1], dist / m * t ** 2 * np.exp(-w * t) / 2.0, atol=1e-10)
    assert np.all(xs[:, 1] >= -1e-12)
    assert abs(xs[-1, 1]) < 1e-9


def test_pd_steady_state_error_broadcasts_per_joint_and_checks_inputs():
    np.testing.assert_allclose(pd_steady_state_error([2.0, -4.0], [1.0, 2.0], 36.0), [2 / 36, -4 / 72], rtol=1e-15)
    with pytest.raises(ValueError, match='^m'):
        pd_steady_state_error(1.0, 0.0, 36.0)
    with pytest.raises(ValueError, match='^kp'):
        pd_steady_state_error(1.0, 2.0, -36.0)
    with pytest.raises(ValueError, match='^d'):
        pd_steady_state_error(float('nan'), 2.0, 36.0)


# -- ServoGains -----------------------------------------------------------------------------------

def test_uniform_gains_and_design_gains():
    g = ServoGains.uniform(2, 36.0, 12.0)
    np.testing.assert_array_equal(g.kp, [36.0, 36.0])
    np.testing.assert_array_equal(g.kv, [12.0, 12.0])
    np.testing.assert_array_equal(g.ki, [0.0, 0.0])
    assert g.n == 2
    h = design(omega_res=12.0, integral=True).gains(3)
    np.testing.assert_array_equal(h.ki, [216.0] * 3)


def test_per_joint_gains_and_default_zero_ki():
    g = ServoGains.per_joint([36.0, 49.0], [12.0, 14.0])
    np.testing.assert_array_equal(g.kp, [36.0, 49.0])
    np.testing.assert_array_equal(g.ki, [0.0, 0.0])
    g = ServoGains.per_joint([1.0], [2.0], [3.0])
    assert g.ki.tolist() == [3.0]


def test_servo_gains_are_immutable():
    g = ServoGains.uniform(2, 36.0, 12.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        g.kp = np.ones(2)
    with pytest.raises(ValueError):
        g.kp[0] = 1.0
    source = np.array([1.0, 2.0])
    h = ServoGains(source, source, source)
    source[0] = 99.0
    assert h.kp[0] == 1.0


@pytest.mark.parametrize('args, name', [
    (([36.0, -1.0], [12.0, 12.0]), 'kp'),
    (([36.0, 36.0], [12.0]), 'kv'),
    (([36.0, 36.0], [12.0, 12.0], [0.0, float('nan')]), 'ki'),
    (([36.0, 36.0], [12.0, float('inf')]), 'kv'),
    (([36.0], [12.0], [0.0, 1.0]), 'ki'),
    (([36.0], [-12.0]), 'kv'),
])
def test_per_joint_rejects_bad_gains_naming_them(args, name):
    with pytest.raises(ValueError, match=f'^{name}'):
        ServoGains.per_joint(*args)


@pytest.mark.parametrize('args, name', [((0, 1.0, 1.0), 'n'), ((2, -1.0, 1.0), 'kp'),
                                        ((2, 1.0, 1.0, float('nan')), 'ki'), ((2.5, 1.0, 1.0), 'n')])
def test_uniform_rejects_bad_arguments(args, name):
    with pytest.raises(ValueError, match=f'^{name}'):
        ServoGains.uniform(*args)


def test_design_is_a_plain_record():
    d = design(omega_res=12.0)
    assert isinstance(d, Design)
    assert d.as_dict() == {'zeta': 1.0, 'omega_n': 6.0, 'omega_res': 12.0, 'kp': 36.0, 'kv': 12.0}


# -- command line ---------------------------------------------------------------------------------

def _cli(*args):
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get('PYTHONPATH', ''))
    return subprocess.run([sys.executable, '-m', 'robot_control.gains', *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=60)


def test_cli_reproduces_the_lecture_example():
    run = _cli('--zeta', '1', '--omega-res', '12')
    assert run.returncode == 0, run.stderr
    assert json.loads(run.stdout) == {'zeta': 1.0, 'omega_n': 6.0, 'omega_res': 12.0, 'kp': 36.0, 'kv': 12.0}


def test_cli_integral_and_explicit_omega_n():
    out = json.loads(_cli('--omega-res', '12', '--integral').stdout)
    assert (out['kp'], out['kv'], out['ki']) == (108.0, 18.0, 216.0)
    out = json.loads(_cli('--omega-n', '5').stdout)
    assert out == {'zeta': 1.0, 'omega_n': 5.0, 'omega_res': None, 'kp': 25.0, 'kv': 10.0}


@pytest.mark.parametrize('args, rule, override', [
    (('--zeta', '0.7', '--omega-res', '12'), 'zeta >= 1', '--allow-underdamped'),
    (('--omega-res', '12', '--omega-n', '8'), 'omega_n <= 0.5 omega_res', '--allow-resonance'),
])
def test_cli_rule_violation_exits_nonzero_naming_the_rule(args, rule, override):
    run = _cli(*args)
    assert run.returncode == 2
    assert rule in run.stderr and run.stdout == ''
    assert run.stderr.rstrip().endswith(f'override: {override}') and '=True' not in run.stderr
    allowed = _cli(*args, override)
    assert allowed.returncode == 0, allowed.stderr
    assert set(json.loads(allowed.stdout)) == {'zeta', 'omega_n', 'omega_res', 'kp', 'kv'}


def test_cli_bad_value_names_the_argument():
    run = _cli('--omega-res', '-3')
    assert run.returncode == 2 and 'argument --omega-res: expected a positive number' in run.stderr


def test_cli_without_omega_names_the_options_to_give():
    run = _cli('--zeta', '1')
    assert run.returncode == 2 and 'give --omega-n or --omega-res' in run.stderr and run.stdout == ''
