"""Control laws: each a function of arrays (its equation, checked at the public entry) and a Law class.

servo: the servo portion v = qdd_d + Kv Ed + Kp E + Ki int E.  Integral: the error integral, clamp and anti-windup.
computed_torque: tau = M v + C qd + g.  independent_joint: tau = Kp E + Kv Ed + Ki int E.
force_1dof: tau = m v + f.  hybrid: hybrid position/force control in operational space.
gravity_compensation: tau = g(q).  impedance: Cartesian impedance in operational space.  saturate: clip to the effort limits, with the saturated mask.
joint_impedance: tau = M qdd_d + C qd + g + K E + D Ed (+ Ki int E), K in N m/rad.
adaptive_computed_torque: Slotine-Li, tau = M qr_dd + C qr_d + g + Y theta_hat - K_D s, the tip's payload estimated.

LAWS is the registry the controller core and the tools ask: law name -> Law class (laws.base).
A new law is one module with its equation and its Law class, and one entry here. Its parameters are its
own (Law.param_rows, Params) and the groups it shares with other laws (Law.parts): the force setup
(force_task.ForceTask: force and hybrid) and the null-space posture (operational_space.Posture: hybrid and
impedance); the controller's parameter table gathers them from here, each group's rows once.
"""
from robot_control.laws.adaptive_computed_torque import AdaptiveComputedTorque, adaptive_computed_torque
from robot_control.laws.base import Errors, Law, Reference, State
from robot_control.laws.computed_torque import ComputedTorque, computed_torque
from robot_control.laws.force import Force, force_1dof, spring_force
from robot_control.laws.gravity_compensation import GravityCompensation, gravity_compensation
from robot_control.laws.hybrid import Hybrid, hybrid, hybrid_error, hybrid_servo
from robot_control.laws.impedance import Impedance, impedance
from robot_control.laws.independent_joint import IndependentJoint, independent_joint
from robot_control.laws.joint_impedance import JointImpedance, joint_impedance
from robot_control.laws.operational_space import operational_space, posture_acceleration
from robot_control.laws.saturation import saturate
from robot_control.laws.integral import Integral
from robot_control.laws.servo import servo
from robot_control.validation import ArgumentError

#: law name -> Law class, in the order the parameter table lists them
LAWS = {law.name: law for law in (ComputedTorque, IndependentJoint, Force, Hybrid, GravityCompensation, Impedance,
                                  JointImpedance, AdaptiveComputedTorque)}


def law_class(name):
    """The Law class registered as `name`; ArgumentError naming `law` with the known names otherwise."""
    try:
        return LAWS[name]
    except (KeyError, TypeError):
        raise ArgumentError('law', f'unknown {name!r}; expected one of {list(LAWS)}') from None


__all__ = ['LAWS', 'Law', 'State', 'Reference', 'Errors', 'law_class', 'Integral', 'servo', 'computed_torque', 'independent_joint',
           'force_1dof', 'spring_force', 'hybrid', 'hybrid_error', 'hybrid_servo', 'operational_space',
           'posture_acceleration', 'gravity_compensation', 'impedance', 'joint_impedance', 'adaptive_computed_torque',
           'saturate']
