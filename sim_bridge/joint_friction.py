"""Joint friction and rotor inertia of the simulated robot: the World's joint-level physics, its parameter
rows and the Coulomb solver. No rclpy, no pybullet.

Per controlled joint i (SI; revolute: N m, rad/s, kg m^2; prismatic: N, m/s, kg):

    (M(q) + diag(I_a)) qdd + h(q, qd) = tau + tau_env - b qd + f,     h = C(q, qd) qd + g(q)

    b    = friction.viscous, N m s/rad or N s/m: the viscous torque -b_i qd_i
    F_c  = friction.coulomb, N m or N: Coulomb friction f_i = -F_c,i sign(qd_i) while the joint slips;
           stiction: a joint at rest stays at rest while the torque that holds it is within F_c,i
           (the breakaway value)
    I_a  = armature, kg m^2 or kg: the rotor inertia reflected through the gear (n^2 I_rotor), added
           to the diagonal of M

tau_env is what the World adds (disturbance, the mass-spring's spring, J^T F of a Cartesian
disturbance). Joints not controlled are held still, so M, h are the controlled joints' block.

Discrete time, the World's semi-implicit Euler step dt (the Coulomb torque is implicit, as Bullet's
velocity motors make it; those motors' iterative solver leaves coupled joints creeping, e.g. 4.9e-4 rad
in 1 s on the iiwa held at 0.9 F_c with default settings, hence the exact solve here):

    qd+ = qd + dt A^-1 (r + f),   A = M + diag(I_a),   r = tau + tau_env - b qd - h (+ tau_c, below)
    f_i = -F_c,i sign(qd+_i) where qd+_i != 0;  |f_i| <= F_c,i where qd+_i = 0

a box-constrained linear complementarity problem, solved exactly by `coulomb_torque`.

How PyBullet is made to simulate it (sim_bridge.joint_physics.JointPhysics):
- viscous: PyBullet's joint damping (changeDynamics jointDamping = b adds -b qd at every step, read
  at the step's start: measured bit-identical to an applied torque -b qd). No call per step.
- Coulomb or armature non-zero: every step reads q, qd, M (calculateMassMatrix), h
  (calculateInverseDynamics) and, under a Cartesian disturbance F, the tip Jacobian; solves the
  equations above for f and qdd = (qd+ - qd) / dt; and sends PyBullet the joint torque
      tau_sent = tau + tau_env_joint + f - I_a qdd,
  for which PyBullet's own M qdd_b = tau_sent - b qd - h + J^T F gives qdd_b = qdd.
  All zero: nothing is read, computed or sent beyond the World's torque.
Constraints: the surface contact, the URDF joint limits and the held joints are solved by PyBullet
after this torque, through M. Their joint torque tau_c of the last step (PyBullet's M (qd - qd+) / dt
added to the tau_c assumed then) is assumed to persist: r includes it, so the friction and the
armature's torque follow the acceleration the constraints allow (exact while tau_c is steady, e.g.
pressing on the surface; one step late when it changes, e.g. at impact). While the brakes hold, the
brakes alone act.
"""
import functools
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from robot_control import validation
from robot_control.param_table import Row, gt_eq, size
from robot_control.validation import ArgumentError

#: the World's `friction` keys and the parameters that carry them
KEYS = ('coulomb', 'viscous', 'armature')
PARAMETERS = {'coulomb': 'friction.coulomb', 'viscous': 'friction.viscous', 'armature': 'armature'}
#: relative slack of the breakaway test |f_i| <= F_c,i (round-off of the linear solve)
BREAKAWAY_RTOL = 1e-12


@dataclass(frozen=True, eq=False)
class JointFriction:
    """coulomb (n,) N m or N, viscous (n,) N m s/rad or N s/m, armature (n,) kg m^2 or kg: non-negative,
    per controlled joint. Immutable; `exact`: Coulomb or armature non-zero (the per-step path)."""

    coulomb: np.ndarray
    viscous: np.ndarray
    armature: np.ndarray

    @classmethod
    def of(cls, n, config=None):
        """From None (all zero), a JointFriction, or a mapping with some of KEYS; ArgumentError naming
        friction.coulomb, friction.viscous or armature."""
        if isinstance(config, JointFriction):
            config = {k: getattr(config, k) for k in KEYS}
        if config is None:
            config = {}
        if not hasattr(config, 'keys'):
            raise ArgumentError('friction', f'expected None or a mapping with keys {list(KEYS)}, got {config!r}')
        unknown = sorted(set(config) - set(KEYS))
        if unknown:
            raise ArgumentError('friction', f'unknown keys {unknown}; expected some of {list(KEYS)}')
        values = {}
        for key in KEYS:
            v = config.get(key)
            v = np.zeros(n) if v is None or len(v) == 0 else validation.vector(PARAMETERS[key], v, n).copy()
            if np.any(v < 0.0):
                raise ArgumentError(PARAMETERS[key], f'expected non-negative values, got {v.tolist()}')
            v.setflags(write=False)
            values[key] = v
        return cls(**values)

    @cached_property
    def active(self):
        """True when any friction or armature is set (a link-side torque sensor then reads less than the motor)."""
        return bool(self.exact or self.viscous.any())

    @cached_property
    def armature_matrix(self):
        """diag(I_a) (n, n), kg m^2 or kg (read-only)."""
        matrix = np.diag(self.armature)
        matrix.setflags(write=False)
        return matrix

    @cached_property
    def exact(self):
        """True when the per-step path runs (Coulomb friction or armature on some joint)."""
        return bool(self.coulomb.any() or self.armature.any())

    def __eq__(self, other):
        return isinstance(other, JointFriction) and all(np.array_equal(getattr(self, k), getattr(other, k))
                                                        for k in KEYS)

    __hash__ = None


def rows(n):
    """The bridge's rows of the joint physics (sim_bridge.bridge_params gathers them): n joints."""
    per_joint = size('joints', 'joint', empty_ok=True)
    zeros = (0.0,) * n
    return [
        Row('friction.coulomb', 'double_array', zeros,
            'Coulomb friction of each joint of the simulated robot, N m or N, in joints order: -F_c sign(qd) while '
            'it slips; a joint at rest stays at rest while the torque holding it is below F_c (stiction).',
            [per_joint, gt_eq(0)]),
        Row('friction.viscous', 'double_array', zeros,
            'Viscous friction of each joint of the simulated robot, N m s/rad or N s/m: the torque -b qd.',
            [per_joint, gt_eq(0)]),
        Row('armature', 'double_array', zeros,
            'Rotor inertia of each joint of the simulated robot reflected through its gear, kg m^2 or kg: '
            'added to the diagonal of M(q).', [per_joint, gt_eq(0)]),
    ]


def from_values(values, n):
    """The JointFriction of checked parameter values (rows' rules hold)."""
    return JointFriction.of(n, {key: values[name] for key, name in PARAMETERS.items()})


def inertia(friction, mass):
    """A = M(q) + diag(I_a) (n, n), kg m^2 or kg: the joints' inertia with their rotors (`friction` a JointFriction)."""
    return mass + friction.armature_matrix


class StepPlan:
    """One step of the equations above, formed before its torque is known: `friction` a JointFriction, inertia
    A = M(q) + diag(I_a) (n, n) (`inertia()`), qd (n,) at the step's start, r0 (n,) the part of r known ahead
    (tau_env - b qd - h + tau_c), dt s; `start` the last step's active sets or None (coulomb_sets). A / dt, the
    known part A qd / dt + r0 of b and the start's ActiveSets are formed here; `solve(x)` adds the torque x (n,)
    to r = r0 + x and finishes the step: what runs once the command is in."""

    def __init__(self, friction, inertia, qd, r0, dt, start=None):
        self.friction, self.qd, self.dt = friction, qd, dt
        self.A_dt = inertia / dt
        self.b0 = self.A_dt @ qd + r0
        self.sets = None if start is None else ActiveSets(self.A_dt, friction.coulomb, *start)

    def solve(self, x=None):
        """(f (n,), qdd (n,), tau_loss (n,), sets) for r = r0 + x (x (n,) N m or N, None: 0): f the implicit
        Coulomb torque, qdd = (qd+ - qd) / dt the step's acceleration, tau_loss = b qd - f + I_a qdd what friction
        and armature take from the motor torque, sets the solver's active sets (coulomb_sets)."""
        fr = self.friction
        f, v, sets = solve_sets(self.A_dt, self.b0 if x is None else self.b0 + x, fr.coulomb, self.sets)
        qdd = (v - self.qd) / self.dt
        return f, qdd, fr.viscous * self.qd - f + fr.armature * qdd, sets


def step_loss(friction, inertia, qd, r, dt, start=None):
    """(f (n,), qdd (n,), tau_loss (n,), sets) of one step of the equations above with r (n,) = tau + tau_env
    - b qd - h (+ tau_c) known at once: StepPlan(friction, inertia, qd, r, dt, start).solve()."""
    return StepPlan(friction, inertia, qd, r, dt, start).solve()


def coulomb_torque(A, b, dt, fc):
    """(f (n,) N m or N, qd+ (n,)): the implicit Coulomb torque of one step and the velocities after it.

    A (n, n) the inertia M + diag(I_a), kg m^2 or kg; b = A qd / dt + r (n,), N m or N (r: every torque
    but Coulomb friction, less h); dt s; fc (n,) >= 0 the breakaway torques. Solves
        A (qd+ - qd) / dt = r + f,   f_i = -fc_i sign(qd+_i) where qd+_i != 0,  |f_i| <= fc_i where qd+_i = 0
    (f_i = 0 where fc_i = 0), that is (A / dt) qd+ - f = b, by active sets (solve_sets)."""
    f, v, _ = coulomb_sets(A, b, dt, fc)
    return f, v


def coulomb_sets(A, b, dt, fc, start=None):
    """(f, qd+, sets): coulomb_torque, its active sets starting from `start` instead of the first guess when given,
    and the consistent sets it ended with (None after the fallback): solve_sets(A / dt, b, fc, start)."""
    return solve_sets(A / dt, b, fc, start)


def solve_sets(A_dt, b, fc, start=None):
    """(f, qd+, sets) of (A / dt) qd+ - f = b under the Coulomb conditions (coulomb_torque), by active sets: A_dt =
    A / dt (n, n), b = A qd / dt + r (n,), fc (n,) >= 0; `start` None, the sets (stuck (n,) bool, the slipping
    joints' directions (n,) of -1, 0, 1) or their ActiveSets for this A_dt. For stuck joints S (qd+_S = 0) and
    slipping joints N (f_N = -fc_N s_N), the unknowns z_i (qd+_i on N, f_i on S) solve one linear system:
        B z = b + f_N,   B = A_dt with column i replaced by -e_i for every i in S
    (B is invertible: det B = +-det A_dt,NN, non-zero as A is positive definite). First guess (_first_guess): a
    joint is stuck when its own friction alone could stop it with the others free, else it slips along its free
    velocity. Then a stuck joint needing more than fc_i breaks away (slips against its holding torque) and a
    slipping joint whose velocity would reverse sticks: all such joints at once, and the first of them alone
    (least index, as Murty's pivoting) once a guess repeats; until consistent (one pass while the arm holds
    still or keeps sliding the same way, the stepping World starting from the last step's sets),
    `_coordinate_descent` if that does not end. With A positive definite the solution is unique: the start
    changes the passes, not f and qd+."""
    if isinstance(start, ActiveSets):
        sets = start
    else:
        sets = ActiveSets(A_dt, fc, *(_first_guess(A_dt, b, fc) if start is None else start))
    seen, least_index = set(), False
    for _ in range(max_passes(len(fc))):
        f, v, wrong = sets.solve(b)
        if wrong is None:                               # at once on most steps
            return f, v, (sets.stuck, sets.sign)
        stuck, sign = sets.stuck, sets.sign
        key = (stuck.tobytes(), sign.tobytes())
        least_index = least_index or key in seen
        seen.add(key)
        if least_index:
            wrong[np.argmax(wrong) + 1:] = False
        sets = ActiveSets(A_dt, fc, stuck ^ wrong, np.where(stuck & wrong, -np.sign(f), sign))
    W = np.linalg.inv(A_dt)
    v_free = W @ b
    f = _coordinate_descent(W, v_free, fc)
    f_exact, v, wrong = ActiveSets(A_dt, fc, (fc > 0.0) & (np.abs(f) < fc * (1.0 - 1e-9)), -np.sign(f)).solve(b)
    return (f_exact, v, None) if wrong is None else (f, v_free + W @ f, None)


def max_passes(n):
    """Active-set passes solve_sets makes on n joints before its fallback: 4 n + 4."""
    return 4 * n + 4


def _first_guess(A_dt, b, fc):
    """(stuck, sign): a joint with friction is stuck when its own friction alone could stop it with the others
    free, |v_free,i| <= W_ii fc_i (W = A_dt^-1 = dt A^-1, v_free = W b the velocities without friction), else it
    slips along v_free,i."""
    has = fc > 0.0
    if not np.count_nonzero(has):
        return has, np.zeros(len(fc))
    W = np.linalg.inv(A_dt)
    v_free = W @ b
    return has & (np.abs(v_free) <= W.diagonal() * fc), np.sign(v_free)


class ActiveSets:
    """solve_sets for the stuck joints `stuck` (n,) bool and the slipping joints' directions `sign` (n,), with
    what depends on A_dt and the sets alone formed once: the slipping joints' friction f_N = -fc_N s_N and B^-1."""

    def __init__(self, A_dt, fc, stuck, sign):
        self.stuck, self.sign = stuck, sign
        slipping = ~stuck
        self.f = -fc * sign * slipping                  # the slipping joints' friction (stuck ones: solve())
        self.B_inv = np.linalg.inv(np.where(stuck, _minus_identity(len(fc)), A_dt))   # column i of -I where i is stuck
        self._along = sign * (slipping & (fc > 0.0))    # s_i of the slipping joints with friction, else 0
        self._limit = np.where(stuck, fc * (1.0 + BREAKAWAY_RTOL), np.inf)  # fc_i of the stuck joints, else inf

    def solve(self, b):
        """(f, qd+, wrong) for these sets; wrong (n,) bool marks the joints whose assumption fails (a stuck joint
        needing more than fc_i, a slipping one whose velocity would reverse), None when none does."""
        stuck = self.stuck
        z = self.B_inv @ (b + self.f)
        wrong = (z * self._along < 0.0) | (np.abs(z) > self._limit)
        return np.where(stuck, z, self.f), np.where(stuck, 0.0, z), wrong if np.count_nonzero(wrong) else None


@functools.lru_cache(maxsize=8)
def _minus_identity(n):
    """-I (n, n), read-only: the columns B takes for the stuck joints (ActiveSets)."""
    out = -np.eye(n)
    out.setflags(write=False)
    return out


def _coordinate_descent(W, v_free, fc, sweeps=1000, tol=1e-15):
    """f: coulomb_torque's fallback, projected Gauss-Seidel on the same problem written with
    W = dt A^-1 and v_free = dt A^-1 b (the minimum of f^T W f / 2 + f^T v_free over |f_i| <= fc_i), until no
    f_i moves by more than tol fc_i."""
    f = np.zeros(len(fc))
    for _ in range(sweeps):
        moved = 0.0
        for i in np.flatnonzero(fc > 0.0):
            new = min(max(f[i] - (v_free[i] + W[i] @ f) / W[i, i], -fc[i]), fc[i])
            moved, f[i] = max(moved, abs(new - f[i]) / fc[i]), new
        if moved <= tol:
            break
    return f
