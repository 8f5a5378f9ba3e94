"""The adaptive law's payload experiment, in process: its figure for docs/theory.md and the runs its test checks.

    python -m dev.adaptive_payload [--out docs/figures/adaptive/adaptive_mass.png]      # from the repository root

The iiwa in sim_bridge.world.World (PyBullet, 1 kHz) carries 2 kg 5 cm out on its flange (PAYLOAD), unknown
to the controller's model; every joint moves DELTA out and back in MOVE s each, REPETITIONS times. The law
adaptive_computed_torque (default parameters: lambda = 6 1/s, composite adaptation) and the same law with the
tracking error alone driving the estimate (GRADIENT_ONLY: Slotine and Li's 1987 adaptation with its best
gain) against computed torque with kp = 36, kv = 12 (the same error equation) with the payload known and unknown. Prints the RMS tracking error per repetition
and the mass estimate at the end of each; draws the estimate's mass and centre of mass over time and the
RMS per repetition.
"""
import argparse
from pathlib import Path

import numpy as np

from robot_control import scenarios
from robot_control.laws.servo import gain_params
from robot_control.core.config import ControllerConfig
from robot_control.core.tick import ControllerCore
from robot_control.gains import ServoGains
from robot_control.models import for_scenario, make_model
from sim_bridge.world import World

from dev.docs_results import save_figure

DT = 0.001
PAYLOAD = (2.0, (0.0, 0.0, 0.05))       # kg, m in the tip frame
MOVE, REPETITIONS, DELTA = 2.0, 3, 0.5  # s per move, out-and-back repetitions, rad per joint
#: computed torque's gains with lambda = 6 1/s: kp = lambda^2, kv = 2 lambda
GAINS = ServoGains(np.full(7, 36.0), np.full(7, 12.0), np.zeros(7))
OUT = Path('docs/figures/adaptive/adaptive_mass.png')
#: the law's parameters with the tracking error alone driving the estimate (no torque prediction)
GRADIENT_ONLY = {'adaptive_prediction_rate': 0.0, 'adaptation_gain': [5.0, 1.0, 0.01]}


def known_model():
    """The iiwa's model with PAYLOAD (what computed torque with the payload known uses)."""
    sc = scenarios.get('iiwa')
    return make_model('urdf', urdf=sc.urdf, joints=sc.joints, tip=sc.tip, payload=PAYLOAD)


def run_iiwa(config, repetitions=REPETITIONS):
    """The controller core on the simulated iiwa carrying PAYLOAD, moving every joint DELTA out and back in
    MOVE s each, `repetitions` times: (errors E per tick (k, 7), the law's estimate theta per tick (k, 10),
    zeros for a law without one)."""
    with World('iiwa', dt=DT, payload=PAYLOAD) as world:
        q0 = world.state()[0].copy()
        core, law = ControllerCore(config), config.control_law
        errors, estimates = [], []
        per_move = int(round(MOVE / DT))
        for k in range(2 * repetitions * per_move):
            if k % per_move == 0:
                core.set_goal(q0 + DELTA if (k // per_move) % 2 == 0 else q0, MOVE)
            q, qd, _ = world.state()
            world.set_torque(core.update(k * DT, q, qd))
            errors.append(core.error[0].copy())
            estimates.append(getattr(law, 'theta', np.zeros(10)).copy())
            world.step(1)
        return np.array(errors), np.array(estimates)


def rms_per_repetition(errors):
    """RMS over every joint of each out-and-back repetition, rad."""
    return np.sqrt((errors.reshape(-1, int(round(2 * MOVE / DT)), 7) ** 2).mean(axis=(1, 2)))


def figure(estimates, gradient_estimates, rms, out):
    """Mass and centre of mass (z) of the estimate over time; RMS per repetition of the three controllers."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    t = np.arange(estimates.shape[0]) * DT
    mass = estimates[:, 0]
    com_z = np.where(mass > 1e-6, estimates[:, 3] / np.maximum(mass, 1e-6), 0.0)
    fig, (ax_m, ax_c, ax_r) = plt.subplots(1, 3, figsize=(10, 3), dpi=80)
    ax_m.plot(t, gradient_estimates[:, 0], ':', label='tracking error alone')
    ax_m.plot(t, mass, label='composite (default)')
    ax_m.axhline(PAYLOAD[0], color='k', ls='--', lw=0.8, label='payload')
    ax_m.set(xlabel='t (s)', ylabel='mass (kg)', title='mass estimate')
    ax_m.legend(loc='lower right', fontsize=7)
    ax_c.plot(t, 100 * com_z)
    ax_c.axhline(100 * PAYLOAD[1][2], color='k', ls='--', lw=0.8)
    ax_c.set(xlabel='t (s)', ylabel='c_z (cm)', title='centre of mass, z', ylim=(0, 10))
    reps = np.arange(1, len(rms['adaptive']) + 1)
    for name, style in (('adaptive', 'o-'), ('adaptive, tracking error alone', 'd-.'),
                        ('computed torque, payload known', 's--'), ('computed torque, payload unknown', 'x:')):
        ax_r.semilogy(reps, rms[name], style, label=name)
    ax_r.set(xlabel='repetition', ylabel='RMS error (rad)', title='tracking', xticks=reps)
    ax_r.legend(fontsize=7)
    save_figure(fig, out)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--out', type=Path, default=OUT)
    args = parser.parse_args(argv)
    iiwa = for_scenario('iiwa')
    errors, estimates = run_iiwa(ControllerConfig(iiwa, law='adaptive_computed_torque'))
    gradient_errors, gradient_estimates = run_iiwa(ControllerConfig(iiwa, law='adaptive_computed_torque',
                                                                    law_params=GRADIENT_ONLY))
    rms = {'adaptive': rms_per_repetition(errors), 'adaptive, tracking error alone': rms_per_repetition(gradient_errors),
           'computed torque, payload known':
               rms_per_repetition(run_iiwa(ControllerConfig(known_model(), law_params=gain_params(GAINS)))[0]),
           'computed torque, payload unknown':
               rms_per_repetition(run_iiwa(ControllerConfig(iiwa, law_params=gain_params(GAINS)))[0])}
    for name, values in rms.items():
        print(f'{name}: RMS per repetition ' + ', '.join(f'{v:.2e}' for v in values) + ' rad')
    per = int(round(2 * MOVE / DT))
    print('mass at the end of each repetition: ' + ', '.join(f'{m:.5f}' for m in estimates[per - 1::per, 0]) + ' kg')
    theta = estimates[-1]
    print(f'final estimate: m {theta[0]:.4f} kg, c {np.round(theta[1:4] / theta[0], 4).tolist()} m, '
          f'inertia {np.round(theta[4:], 5).tolist()} kg m^2')
    figure(estimates, gradient_estimates, rms, args.out)
    print(f'wrote {args.out}')


if __name__ == '__main__':
    main()
