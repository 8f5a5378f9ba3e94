"""Servo gains from the lecture's performance specification (section 2.2.1, "Performance Specifications").

The error equation e'' + kv e' + kp e = 0 is matched to s^2 + 2 zeta w_n s + w_n^2 = 0:

    kp = w_n^2,  kv = 2 zeta w_n,  with  zeta >= 1 (no underdamping, for safety)
                                   and   w_n <= 0.5 w_res (w_res: lowest structural resonance).

PID (lecture, "Disturbance Rejection"): the closed loop becomes s^3 + kv s^2 + kp s + ki = 0. Adding
any ki > 0 to the PD gains splits the critically damped double root into a complex pair, so the
cubic is placed instead: the PD factor keeps its zeta and w_n and a third real pole goes at -w_n,

    (s^2 + 2 zeta w_n s + w_n^2)(s + w_n)  =>  kv = (2 zeta + 1) w_n,  kp = (1 + 2 zeta) w_n^2,  ki = w_n^3.

With zeta >= 1 all three roots are real and negative; with zeta = 1 they form a triple root at
-w_n, so the fastest pole is w_n itself and the resonance rule still holds. The integral also puts
a zero at -ki/kp = -w_n / (1 + 2 zeta) in the response to the set point: a set-point step from rest
overshoots (about 25 % at zeta = 1) although no pole is complex; a smooth reference (a quintic move)
is followed without overshoot.

Units: kp in 1/s^2, kv in 1/s, ki in 1/s^3, w_n and w_res in rad/s (computed-torque servo, where
the plant is a unit mass). Command line:

    python -m robot_control.gains --zeta 1 --omega-res 12      # the lecture's example: kv 12, kp 36
"""
import argparse
import dataclasses
import json
import sys

import numpy as np

from robot_control.validation import ArgumentError
from robot_control import validation

RULE_ZETA = 'zeta >= 1 (the lecture: no underdamped response, for safety)'
RULE_RESONANCE = 'omega_n <= 0.5 omega_res (the lecture: do not excite the structural resonance)'


class GainRuleError(ArgumentError):
    """A design breaks one of the lecture's rules: `name` is the gain parameter, `rule` the rule as text,
    `override` the design() keyword that allows it (its reason names it as the caller's reader does)."""

    def __init__(self, name, reason, rule, override):
        super().__init__(name, reason)
        self.rule = rule
        self.override = override


def keyword(override):
    """A rule's override in the library's terms: the keyword argument of design(), allow_underdamped=True."""
    return f'{override}=True'


def flag(override):
    """A rule's override in the command line's terms: --allow-underdamped."""
    return '--' + override.replace('_', '-')


def _gain_vector(name, value, n):
    """`value` as a read-only finite non-negative (n,) array, or ValueError naming `name`."""
    a = validation.vector(name, value, n).copy()
    if a.size and min(a.tolist()) < 0.0:
        raise ArgumentError(name, f'expected non-negative gains, got {a.tolist()}')
    a.flags.writeable = False
    return a


@dataclasses.dataclass(frozen=True, eq=False)
class ServoGains:
    """Diagonals of Kp, Kv, Ki in v = qdd_d + Kv Ed + Kp E + Ki int E; each (n,), finite, >= 0, read-only.

    Units 1/s^2, 1/s, 1/s^3 in the computed-torque servo (unit-mass plant); the independent-joint law
    reads the same fields as torque gains. ki defaults to zeros (no integral action).
    """

    kp: np.ndarray
    kv: np.ndarray
    ki: np.ndarray = None

    def __post_init__(self):
        kp = _gain_vector('kp', self.kp, None)
        n = kp.shape[0]
        object.__setattr__(self, 'kp', kp)
        object.__setattr__(self, 'kv', _gain_vector('kv', self.kv, n))
        object.__setattr__(self, 'ki', _gain_vector('ki', np.zeros(n) if self.ki is None else self.ki, n))

    @classmethod
    def _of_checked(cls, kp, kv, ki):
        """ServoGains of (n,) arrays that are already finite and >= 0 (made read-only here, not copied)."""
        gains = object.__new__(cls)
        for name, a in (('kp', kp), ('kv', kv), ('ki', ki)):
            a.flags.writeable = False
            object.__setattr__(gains, name, a)
        return gains

    @property
    def n(self):
        """Number of joints."""
        return self.kp.shape[0]

    @classmethod
    def uniform(cls, n, kp, kv, ki=0.0):
        """The same scalar kp, kv, ki on each of n joints."""
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise ArgumentError('n', f'expected a positive integer, got {n!r}')
        scalars = [validation.scalar(name, value) for name, value in (('kp', kp), ('kv', kv), ('ki', ki))]
        return cls(*(np.full(int(n), x) for x in scalars))

    @classmethod
    def per_joint(cls, kp_list, kv_list, ki_list=None):
        """One kp, kv (and ki, zeros when None) per joint; all lists of the same length n."""
        return cls(kp_list, kv_list, ki_list)


@dataclasses.dataclass(frozen=True)
class Design:
    """A designed servo: zeta, omega_n (rad/s), omega_res (rad/s or None), kp (1/s^2), kv (1/s), ki (1/s^3)."""

    zeta: float
    omega_n: float
    omega_res: float | None
    kp: float
    kv: float
    ki: float

    def gains(self, n):
        """These gains on each of n joints, as ServoGains."""
        return ServoGains.uniform(n, self.kp, self.kv, self.ki)

    def as_dict(self):
        """JSON-ready dict {zeta, omega_n, omega_res, kp, kv[, ki]}; ki only for a PID design (ki > 0)."""
        out = {'zeta': self.zeta, 'omega_n': self.omega_n, 'omega_res': self.omega_res,
               'kp': self.kp, 'kv': self.kv}
        if self.ki > 0.0:
            out['ki'] = self.ki
        return out


def _optional_positive(name, value):
    return None if value is None else validation.scalar(name, value, positive=True)


def _check_rules(zeta, omega_n, omega_res, allow_underdamped, allow_resonance, name_override):
    """Raise GainRuleError if zeta < 1 or omega_n > 0.5 omega_res, unless allowed; its reason names the
    override as name_override(keyword) gives it."""
    if zeta < 1.0 and not allow_underdamped:
        raise GainRuleError('zeta', f'{zeta:g} breaks the rule {RULE_ZETA}; '
                            f'override: {name_override("allow_underdamped")}', RULE_ZETA, 'allow_underdamped')
    if omega_res is not None and omega_n > 0.5 * omega_res and not allow_resonance:
        raise GainRuleError('omega_n', f'{omega_n:g} rad/s > 0.5 * {omega_res:g} rad/s breaks the rule '
                            f'{RULE_RESONANCE}; override: {name_override("allow_resonance")}', RULE_RESONANCE,
                            'allow_resonance')


def pid_gains(zeta, omega_n):
    """(kp, kv, ki) with s^3 + kv s^2 + kp s + ki = (s^2 + 2 zeta w_n s + w_n^2)(s + w_n)."""
    kv = (2.0 * zeta + 1.0) * omega_n
    kp = (1.0 + 2.0 * zeta) * omega_n ** 2
    ki = omega_n ** 3
    return kp, kv, ki


def design(zeta=1.0, omega_res=None, omega_n=None, integral=False,
           allow_underdamped=False, allow_resonance=False, name_override=keyword):
    """kp = w_n^2, kv = 2 zeta w_n (PD) or the PID placement of pid_gains; w_n defaults to 0.5 w_res.

    zeta: damping ratio (> 0; >= 1 unless allow_underdamped); omega_res, omega_n in rad/s (> 0),
    at least one given; omega_n <= 0.5 omega_res unless allow_resonance. Raises GainRuleError
    (a ValueError) naming the broken rule and its override, as name_override(keyword name) words it
    for the caller's reader (default keyword: allow_underdamped=True; the CLI: flag); bad numbers
    raise ValueError naming the argument.
    """
    zeta = validation.scalar('zeta', zeta, positive=True)
    omega_res = _optional_positive('omega_res', omega_res)
    omega_n = _optional_positive('omega_n', omega_n)
    if omega_n is None:
        if omega_res is None:
            raise ArgumentError('omega_n', 'give omega_n or omega_res (then omega_n = 0.5 omega_res)')
        omega_n = 0.5 * omega_res
    _check_rules(zeta, omega_n, omega_res, allow_underdamped, allow_resonance, name_override)
    if integral:
        kp, kv, ki = pid_gains(zeta, omega_n)
    else:
        kp, kv, ki = omega_n ** 2, 2.0 * zeta * omega_n, 0.0
    return Design(zeta, omega_n, omega_res, kp, kv, ki)


def _finite_array(name, value, positive=False):
    """`value` as a finite float array (any shape), > 0 if `positive`; else ValueError naming `name`."""
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ArgumentError(name, f'expected numbers, got {value!r}') from exc
    if not np.all(np.isfinite(a)) or (positive and not np.all(a > 0.0)):
        kind = 'positive' if positive else 'finite'
        raise ArgumentError(name, f'expected {kind} values, got {a.tolist()}')
    return a


def pd_steady_state_error(d, m, kp):
    """e_ss = d / (m kp): PD error under a constant disturbance d (N or N m), mass m (kg or kg m^2), kp (1/s^2).

    Scalars give a float; arrays broadcast (per joint).
    """
    d = _finite_array('d', d)
    m, kp = _finite_array('m', m, positive=True), _finite_array('kp', kp, positive=True)
    e = d / (m * kp)
    return float(e) if e.ndim == 0 else e


def _parser():
    p = argparse.ArgumentParser(prog='python -m robot_control.gains',
                                description='Servo gains from the lecture: kp = w_n^2, kv = 2 zeta w_n.')
    p.add_argument('--zeta', type=float, default=1.0, help='damping ratio (>= 1 unless --allow-underdamped)')
    p.add_argument('--omega-res', type=float, default=None, help='lowest structural resonance, rad/s')
    p.add_argument('--omega-n', type=float, default=None, help='natural frequency, rad/s (default 0.5 omega_res)')
    p.add_argument('--integral', action='store_true', help='PID: also place ki (third pole at -omega_n)')
    p.add_argument('--allow-underdamped', action='store_true', help='allow zeta < 1')
    p.add_argument('--allow-resonance', action='store_true', help='allow omega_n > 0.5 omega_res')
    return p


def main(argv=None):
    """CLI: print the design as JSON on stdout; a broken rule or bad value exits 2 with the reason on stderr,
    naming the option (--omega-res) and a rule's override flag (--allow-underdamped)."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.omega_n is None and args.omega_res is None:
        return _refuse(parser, 'give --omega-n or --omega-res (then omega_n = 0.5 omega_res)')
    try:
        result = design(args.zeta, args.omega_res, args.omega_n, args.integral,
                        args.allow_underdamped, args.allow_resonance, name_override=flag)
    except ArgumentError as exc:  # GainRuleError included: the message names the rule
        return _refuse(parser, f'argument {flag(exc.name)}: {exc.reason}')
    print(json.dumps(result.as_dict()))
    return 0


def _refuse(parser, message):
    """argparse's error line (without the usage: the options were well-formed) on stderr; exit status 2."""
    print(f'{parser.prog}: error: {message}', file=sys.stderr)
    return 2


if __name__ == '__main__':
    sys.exit(main())
