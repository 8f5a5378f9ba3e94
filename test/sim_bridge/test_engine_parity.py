"""Three rigid-body engines, one URDF: Pinocchio, PyBullet and MuJoCo agree on the dynamics.

For every scenario (each is URDF-backed: the closed-form robots by their shipped URDFs), from the
copy the PyBullet world simulates (World.urdf), at 50 random states (q inside the URDF travel,
qd in [-2, 2], qdd in [-5, 5]): the mass matrix M(q), the gravity torque g(q) and the inverse
dynamics tau = M(q) qdd + C(q, qd) qd + g(q) of PyBullet (calculateMassMatrix,
calculateInverseDynamics) and of MuJoCo (mj_fullM, mj_rne) equal Pinocchio's (CRBA, RNEA) within
1e-9 (kg m^2, kg; N m, N). Measured: at most 8e-14 (MuJoCo, Panda) and 3e-14 (PyBullet). A wrong
mass matrix factorisation, inertia, axis, sign or gravity in either engine fails here.
"""
import mujoco
import numpy as np
import pybullet as p
import pytest

from robot_control import scenarios
from robot_control.models.urdf_model import UrdfModel
from sim_bridge import mujoco_model, physics_check
from sim_bridge.world import World

TOL = 1e-9
STATES = 50


def _random_states(model, rng):
    """STATES (q, qd, qdd) triples, q uniform inside the finite URDF travel (else in [-pi, pi])."""
    lower, upper = model.position_limits
    finite = np.isfinite(lower) & np.isfinite(upper)
    lower, upper = np.where(finite, lower, -np.pi), np.where(finite, upper, np.pi)
    for _ in range(STATES):
        yield (rng.uniform(lower, upper), rng.uniform(-2.0, 2.0, model.n), rng.uniform(-5.0, 5.0, model.n))


class _PyBullet:
    """M, g, inverse dynamics of the PyBullet world's body, restricted to the controlled joints (the
    others at rest at 0: the world's position hold)."""

    def __init__(self, world):
        self.client, self.body = world.client, world.body
        names = list(physics_check.movable_joints(self.client, self.body))
        self.all, self.sel = len(names), [names.index(j) for j in world.joint_names]

    def _full(self, x):
        out = [0.0] * self.all
        for k, v in zip(self.sel, x):
            out[k] = float(v)
        return out

    def M(self, q):
        m = np.array(p.calculateMassMatrix(self.body, self._full(q), physicsClientId=self.client))
        return m[np.ix_(self.sel, self.sel)]

    def inverse_dynamics(self, q, qd, qdd):
        tau = p.calculateInverseDynamics(self.body, self._full(q), self._full(qd), self._full(qdd),
                                         physicsClientId=self.client)
        return np.array(tau)[self.sel]


class _MuJoCo:
    """M, g, inverse dynamics of the MuJoCo model of the same URDF (sim_bridge.mujoco_model)."""

    def __init__(self, world):
        with open(world.urdf, encoding='utf-8') as f:
            self.model = mujoco_model.load(f.read(), world.joint_names, world.gravity, world.dt)
        self.data = mujoco.MjData(self.model)
        self.qadr, self.dadr = mujoco_model.dofs(self.model, world.joint_names)

    def _at(self, q, qd):
        self.data.qpos[self.qadr], self.data.qvel[self.dadr] = q, qd
        mujoco.mj_forward(self.model, self.data)

    def M(self, q):
        self._at(q, 0.0)
        return mujoco_model.mass_matrix(self.model, self.data)[np.ix_(self.dadr, self.dadr)]

    def inverse_dynamics(self, q, qd, qdd):
        self._at(q, qd)
        qacc = np.zeros(self.model.nv)
        qacc[self.dadr] = qdd
        return mujoco_model.inverse_dynamics(self.model, self.data, qacc)[self.dadr]


def _largest_differences(reference, engine, states):
    """Largest |difference| of M, g and inverse dynamics of `engine` from `reference` over `states`."""
    dm = dg = dt = 0.0
    for q, qd, qdd in states:
        zero = np.zeros_like(q)
        dm = max(dm, np.abs(engine.M(q) - reference.M(q)).max())
        dg = max(dg, np.abs(engine.inverse_dynamics(q, zero, zero) - reference.g(q)).max())
        dt = max(dt, np.abs(engine.inverse_dynamics(q, qd, qdd) - reference.inverse_dynamics(q, qd, qdd)).max())
    return {'M': dm, 'g': dg, 'inverse dynamics': dt}


@pytest.mark.parametrize('name', tuple(scenarios.SCENARIOS))
def test_pinocchio_pybullet_and_mujoco_agree(name):
    world = World(name, surface=False)
    try:
        with open(world.urdf, encoding='utf-8') as f:
            reference = UrdfModel(f.read(), joints=list(world.joint_names), gravity=(0.0, 0.0, -world.gravity))
        states = list(_random_states(reference, np.random.default_rng(7)))
        for engine in (_PyBullet(world), _MuJoCo(world)):
            worst = _largest_differences(reference, engine, states)
            print(f'{name} {type(engine).__name__[1:]}: ' + ', '.join(f'{k} {v:.1e}' for k, v in worst.items()))
            assert max(worst.values()) < TOL, (name, type(engine).__name__, worst)
    finally:
        world.close()


def test_the_comparison_sees_a_wrong_inertia():
    """The check can fail: the iiwa's MuJoCo model with link 4 1 g heavier differs from Pinocchio's."""
    world = World('iiwa', surface=False)
    try:
        with open(world.urdf, encoding='utf-8') as f:
            reference = UrdfModel(f.read(), joints=list(world.joint_names), gravity=(0.0, 0.0, -world.gravity))
        engine = _MuJoCo(world)
        engine.model.body_mass[engine.model.body('lbr_iiwa_link_4').id] += 1e-3
        mujoco.mj_setConst(engine.model, engine.data)
        worst = _largest_differences(reference, engine, list(_random_states(reference, np.random.default_rng(7)))[:5])
        assert worst['g'] > 1e-4 and worst['M'] > 1e-5
    finally:
        world.close()
