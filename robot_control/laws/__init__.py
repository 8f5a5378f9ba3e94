"""Control laws as pure functions of arrays (the lecture's notation; DESIGN section 4).

servo + Integral: the servo portion v = qdd_d + Kv Ed + Kp E + Ki int E, and the error integral.
computed_torque: tau = M v + C qd + g.  independent_joint: tau = Kp E + Kv Ed + Ki int E.
force_1dof: tau = m v + f.  hybrid: operational-space hybrid position/force control.
saturate: clip to the effort limits, with the mask that holds the integral (anti-windup).
"""
from robot_control.laws.computed_torque import computed_torque
from robot_control.laws.force import force_1dof, spring_force
from robot_control.laws.hybrid import (hybrid, hybrid_error, hybrid_servo, operational_space,
                                       posture_acceleration, task_space_torque)
from robot_control.laws.independent_joint import independent_joint
from robot_control.laws.saturation import saturate
from robot_control.laws.servo import Integral, servo

__all__ = ['Integral', 'servo', 'computed_torque', 'independent_joint', 'force_1dof', 'spring_force',
           'hybrid', 'hybrid_error', 'hybrid_servo', 'operational_space', 'posture_acceleration',
           'task_space_torque', 'saturate']
