"""B1's cases of the laws for a real arm (benchmarks.bench.law_cases): joint impedance and adaptive computed
torque on the iiwa, each as the controller runs it per tick (benchmarks.bench.LawTick of its ControllerConfig)
and as its public checked function on the same inputs.

- 'joint_impedance_7dof': law joint_impedance, stiffness REAL_STIFFNESS of the demo's iiwa, designed damping
  (ratio 1), with its integral (ki = K / 1 s) and the tick's int_E;
- 'adaptive_7dof': law adaptive_computed_torque with its defaults (the composite adaptation on: each tick
  samples the torque prediction of the step from the tick before, adapts, projects and evaluates the law),
  the rows 1 ms apart.
"""
import numpy as np


def real_arm_cases(iiwa, states):
    """{name: (fn, inputs)}: 'joint_impedance_7dof', 'adaptive_7dof' and their '_checked' functions on `states`
    (benchmarks.bench._iiwa_states of the iiwa model `iiwa`)."""
    from benchmarks.bench import law_tick
    from robot_control.core.config import ControllerConfig
    from robot_control.laws import adaptive_computed_torque, joint_impedance
    from robot_control.tools.demo_experiments import REAL_STIFFNESS
    K = np.array(REAL_STIFFNESS['iiwa'])
    impedance = ControllerConfig(iiwa, law='joint_impedance', integral=True,
                                 law_params={'joint_stiffness': tuple(K)})
    adaptive = ControllerConfig(iiwa, law='adaptive_computed_torque')
    law = adaptive.control_law
    theta = np.zeros(10)
    return {
        'joint_impedance_7dof': law_tick(impedance, [(q, qd, (q_d, qd_d, qdd_d), int_E)
                                                     for q, qd, q_d, qd_d, qdd_d, int_E in states]),
        'joint_impedance_7dof_checked': (joint_impedance, [(iiwa, q, qd, q_d, qd_d, qdd_d, K, None, 1.0, None, int_E)
                                                           for q, qd, q_d, qd_d, qdd_d, int_E in states]),
        'adaptive_7dof': law_tick(adaptive, [(q, qd, (q_d, qd_d, qdd_d), None) for q, qd, q_d, qd_d, qdd_d, _ in states]),
        'adaptive_7dof_checked': (adaptive_computed_torque, [(iiwa, q, qd, q_d, qd_d, qdd_d, theta, law.lam)
                                                             for q, qd, q_d, qd_d, qdd_d, _ in states]),
    }
