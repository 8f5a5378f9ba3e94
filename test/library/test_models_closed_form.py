"""Closed-form models against the lecture's printed equations and rigid-body properties."""
import math

import numpy as np
import pytest

from robot_control.models import CLOSED_FORM, make_model

RNG = np.random.default_rng(20261122)


def test_polar_example_matches_lecture_numbers():
    """Lecture example, m = 2 kg: M = diag(2r^2, 2), C qd = [4 r rd th1d, -2 r th1d^2], g = 19.6[r c1, s1]."""
    model = make_model('polar_two_link', m=2.0, gravity=9.8)
    for _ in range(100):
        q = RNG.uniform([-np.pi, 0.1], [np.pi, 1.5])
        qd = RNG.uniform(-3, 3, 2)
        th1, r = q
        np.testing.assert_allclose(model.M(q), [[2 * r * r, 0], [0, 2]], rtol=0, atol=1e-12)
        np.testing.assert_allclose(model.C_qd(q, qd), [4 * r * qd[1] * qd[0], -2 * r * qd[0] ** 2],
                                   rtol=0, atol=1e-12)
        np.testing.assert_allclose(model.g(q), [19.6 * r * math.cos(th1), 19.6 * math.sin(th1)],
                                   rtol=0, atol=1e-12)


def test_single_link_matches_lecture():
    model = make_model('single_link', m=1.5, l=0.7, gravity=9.81)
    q, qdd = np.array([0.3]), np.array([2.0])
    tau = model.inverse_dynamics(q, np.zeros(1), qdd)
    assert tau[0] == pytest.approx(1.5 * 0.49 * 2.0 + 1.5 * 9.81 * 0.7 * math.cos(0.3), abs=1e-12)


@pytest.mark.parametrize('name', ['polar_two_link', 'planar_two_link', 'single_link'])
def test_mdot_minus_2c_is_skew(name):
    model = make_model(name)
    for _ in range(50):
        q = RNG.uniform(0.2, 1.2, model.n)
        qd = RNG.uniform(-2, 2, model.n)
        h = 1e-6
        mdot = (model.M(q + h * qd) - model.M(q - h * qd)) / (2 * h)
        n = mdot - 2 * model.C(q, qd)
        np.testing.assert_allclose(n, -n.T, atol=1e-7)
        np.testing.assert_allclose(model.C(q, qd) @ qd, model.C_qd(q, qd), atol=1e-12)


@pytest.mark.parametrize('name', sorted(CLOSED_FORM))
def test_mass_matrix_symmetric_positive_definite(name):
    model = make_model(name)
    for _ in range(50):
        q = RNG.uniform(0.2, 1.2, model.n)
        m = model.M(q)
        np.testing.assert_allclose(m, m.T, atol=1e-14)
        assert np.all(np.linalg.eigvalsh(m) > 0)


@pytest.mark.parametrize('name', ['single_link', 'polar_two_link', 'planar_two_link'])
def test_jacobian_and_bias_match_finite_differences(name):
    model = make_model(name)
    for _ in range(20):
        q = RNG.uniform(0.2, 1.2, model.n)
        qd = RNG.uniform(-2, 2, model.n)
        h = 1e-6
        j_fd = np.column_stack([(model.fk(q + h * e) - model.fk(q - h * e)) / (2 * h)
                                for e in np.eye(model.n)])
        np.testing.assert_allclose(model.J(q), j_fd, atol=1e-8)
        jdot = (model.J(q + h * qd) - model.J(q - h * qd)) / (2 * h)
        np.testing.assert_allclose(model.Jdot_qd(q, qd), jdot @ qd, atol=1e-7)


def test_planar_coriolis_first_row_differs_from_lecture_typo():
    """The lecture prints +m2 l1 l2 (th1d^2 + 2 th1d th2d) s2; Lagrange gives -m2 l1 l2 (2 th1d th2d + th2d^2) s2."""
    model = make_model('planar_two_link', m1=1.0, m2=2.0, l1=0.5, l2=0.4)
    q, qd = np.array([0.1, 0.7]), np.array([1.3, -0.4])
    h = 2.0 * 0.5 * 0.4 * math.sin(0.7)
    assert model.C_qd(q, qd)[0] == pytest.approx(-h * (2 * 1.3 * -0.4 + 0.16), abs=1e-12)


@pytest.mark.parametrize('bad', [{'m': 0.0}, {'m': -1.0}, {'m': float('nan')}, {'m': 'heavy'}])
def test_non_positive_or_non_numeric_mass_is_rejected_naming_it(bad):
    with pytest.raises(ValueError, match='^m:'):
        make_model('polar_two_link', **bad)


def test_unknown_model_and_parameter_are_named():
    with pytest.raises(ValueError, match='unknown closed-form model'):
        make_model('scara')
    with pytest.raises(ValueError, match='bad parameters'):
        make_model('single_link', mass=1.0)


@pytest.mark.parametrize('name', sorted(CLOSED_FORM))
def test_public_methods_check_their_arguments_naming_them(name):
    """polar.g of a length-3 q, polar.M([0.3]): an ArgumentError naming q, never a silently ignored
    entry or an IndexError; the same for qd, qdd and tau."""
    model = make_model(name)
    n, good = model.n, np.full(model.n, 0.3)
    for call, arg in [(lambda v: model.M(v), 'q'), (lambda v: model.g(v), 'q'), (lambda v: model.C_qd(good, v), 'qd'),
                      (lambda v: model.inverse_dynamics(good, good, v), 'qdd'),
                      (lambda v: model.forward_dynamics(good, good, v), 'tau'), (lambda v: model.fk(v), 'q'),
                      (lambda v: model.J(v), 'q'), (lambda v: model.Jdot_qd(good, v), 'qd')]:
        for bad in (np.zeros(n + 1), np.zeros(max(n - 1, 0)), [np.nan] * n, 'fast'):
            with pytest.raises(ValueError, match=f'^{arg}:') as info:
                call(bad)
            assert info.value.name == arg


def test_inverse_and_forward_dynamics_are_composed_from_the_terms():
    """inverse_dynamics = M qdd + C qd + g and forward_dynamics its inverse, for every closed form."""
    for name in sorted(CLOSED_FORM):
        model = make_model(name)
        q, qd, qdd = RNG.uniform(0.2, 1.2, (3, model.n))
        tau = model.inverse_dynamics(q, qd, qdd)
        np.testing.assert_allclose(tau, model.M(q) @ qdd + model.C_qd(q, qd) + model.g(q), rtol=0, atol=1e-12)
        np.testing.assert_allclose(model.forward_dynamics(q, qd, tau), qdd, rtol=1e-12, atol=1e-12)
