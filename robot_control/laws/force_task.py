"""The force setup the force laws share: the force axes, the environment, the force servo's gains, the force
feedback, the force reference's ramp and the lost-contact guard.

A law that uses force declares it (Law.parts = (ForceTask,)): the controller's parameter table then lists
PARAM_ROWS once, however many laws use it, and the law's Params holds a ForceTask (its field
`force_task`), fitted to the model's task axes when the configuration is made. The controller core
measures the force (f = k_e (x - x_e) or the sensor's, f + fdot T), ramps the force reference and
guards lost contact from the ForceTask of the active law (Law.force_task); a law without it has
NO_FORCE_TASK, with no force axes.
"""
import dataclasses
import functools
import math

import numpy as np

from robot_control import validation
from robot_control.gains import ServoGains
from robot_control.param_table import Row, gt, gt_eq, one_of, size, unique
from robot_control.validation import ArgumentError

FORCE_FEEDBACK = ('sensor', 'model')
#: the force servo's gains, as the parameters name them
GAIN_NAMES = ('force_kp', 'force_kv', 'force_ki')

#: the force setup's parameters, in the order of the controller's parameter table
PARAM_ROWS = (
    Row('force_axes', 'string_array', (), "force-controlled task axes (names of the model's task axes, e.g. x)",
        [unique()]),
    Row('k_e', 'double_array', (), 'environment stiffness per force axis, N/m',
        [size('force_axes', 'force axis'), gt(0)]),
    Row('x_e', 'double_array', (), 'environment location per force axis, m', [size('force_axes', 'force axis')]),
    Row('force_kp', 'double_array', (), 'explicit force servo kp per force axis (empty = designed), 1/s^2',
        [size('force_axes', 'force axis', empty_ok=True), gt_eq(0)]),
    Row('force_kv', 'double_array', (), 'explicit force servo kv per force axis (empty = designed), 1/s',
        [size('force_axes', 'force axis', empty_ok=True), gt_eq(0)]),
    Row('force_ki', 'double_array', (), 'explicit force servo ki per force axis (empty = designed), 1/s^3',
        [size('force_axes', 'force axis', empty_ok=True), gt_eq(0)]),
    Row('force_feedback', 'string', 'sensor',
        "contact force: 'sensor' (ft_sensor/wrench) or 'model' (f = k_e (x - x_e))", [one_of(FORCE_FEEDBACK)]),
    Row('force_lead_time', 'double', 0.0, 'force laws use the force predicted this far ahead, f + fdot T, '
        "s; the control period compensates the command hold (0 = the lecture's law)", [gt_eq(0)]),
    Row('force_ramp_time', 'double', 0.5, 'duration of a force reference change (quintic), s; 0 = step', [gt_eq(0)]),
    Row('contact_max_travel', 'double', 0.05,
        'lost-contact guard (force, hybrid): largest travel past the surface that the measured force '
        'does not explain before the force axis is held in position, m; .inf = off', [gt(0)], inf=True),
    Row('contact_max_speed', 'double', 0.5,
        'lost-contact guard (force, hybrid): largest speed along a force axis before it is held in '
        'position, m/s; .inf = off', [gt(0)], inf=True),
)


@dataclasses.dataclass(frozen=True, eq=False)
class ForceTask:
    """The force setup (PARAM_ROWS), checked on creation (ArgumentError naming the parameter):
    force_axes: names of the force-controlled task axes, unique; k_e (N/m, > 0) and x_e (m) one per
    force axis, held as read-only (k,) arrays; force_kp (1/s^2), force_kv (1/s), force_ki (1/s^3, empty =
    zeros), >= 0, one per force axis: the force servo's gains, needed with force axes (the controller's
    parameter layer writes the designed ones), held also as `gains`, ServoGains (k,) (None without);
    force_feedback 'sensor' (the measured force) or 'model' (f = k_e (x - x_e)); force_lead_time T, s >= 0:
    the force laws use f + fdot T (0 = the lecture's law); force_ramp_time: duration of a force reference
    change, s >= 0 (0 = step); contact_max_travel (m) and contact_max_speed (m/s), > 0, inf = off: the
    lost-contact guard (robot_control.core.contact).
    fitted(task_axes) orders the axes (and k_e, x_e and the gains with them) as the model's task axes and
    gives the mask (m,) over them."""

    force_axes: tuple = ()
    k_e: np.ndarray = ()
    x_e: np.ndarray = ()
    force_kp: np.ndarray = ()
    force_kv: np.ndarray = ()
    force_ki: np.ndarray = ()
    force_feedback: str = 'sensor'
    force_lead_time: float = 0.0
    force_ramp_time: float = 0.5
    contact_max_travel: float = math.inf
    contact_max_speed: float = math.inf
    mask: np.ndarray = dataclasses.field(default=None, repr=False)
    gains: ServoGains = dataclasses.field(default=None, init=False, repr=False)

    param_rows = PARAM_ROWS
    field = 'force_task'       # the name a law's Params holds it under

    def __post_init__(self):
        set_ = functools.partial(object.__setattr__, self)
        axes = tuple(self.force_axes)
        if len(set(axes)) != len(axes):
            raise ArgumentError('force_axes', f'duplicate axes in {list(axes)}')
        axes = validation.names('force_axes', axes)
        k = len(axes)
        k_e = validation.vector('k_e', self.k_e, k) if k else np.zeros(0)
        if np.any(k_e <= 0.0):
            raise ArgumentError('k_e', f'expected positive stiffness (N/m), got {k_e.tolist()}')
        set_('force_axes', axes)
        set_('k_e', validation.read_only(k_e))
        set_('x_e', validation.read_only(validation.vector('x_e', self.x_e, k) if k else np.zeros(0)))
        self._set_gains(set_, axes)
        if self.force_feedback not in FORCE_FEEDBACK:
            raise ArgumentError('force_feedback', f'unknown {self.force_feedback!r}; expected one of '
                                                  f'{list(FORCE_FEEDBACK)}')
        for name in ('force_lead_time', 'force_ramp_time'):
            set_(name, validation.scalar(name, getattr(self, name), nonnegative=True))
        for name in ('contact_max_travel', 'contact_max_speed'):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0.0:
                raise ArgumentError(name, f'expected a positive bound (inf = off), got {value!r}')
            set_(name, float(value))
        if self.mask is not None:
            set_('mask', validation.read_only(self.mask, bool))

    def _set_gains(self, set_, axes):
        k = len(axes)
        for name in GAIN_NAMES:
            gain = validation.vector(name, getattr(self, name))
            if gain.shape[0] not in (0, k):
                raise ArgumentError(name, f'expected {k} gains (one per force axis {list(axes)}), got {gain.tolist()}')
            if min(gain.tolist(), default=0.0) < 0.0:
                raise ArgumentError(name, f'expected non-negative gains, got {gain.tolist()}')
            set_(name, validation.read_only(gain))
        given = bool(k and self.force_kp.size and self.force_kv.size)
        set_('gains', ServoGains(self.force_kp, self.force_kv, self.force_ki if self.force_ki.size else None)
             if given else None)

    def _key(self):
        return (self.force_axes, tuple(self.k_e.tolist()), tuple(self.x_e.tolist()),
                *(tuple(getattr(self, name).tolist()) for name in GAIN_NAMES), self.force_feedback,
                self.force_lead_time, self.force_ramp_time, self.contact_max_travel, self.contact_max_speed)

    def __eq__(self, other):
        return isinstance(other, ForceTask) and self._key() == other._key()

    def __hash__(self):
        return hash(self._key())

    def fitted(self, model):
        """This setup on the `model`'s task axes: the force axes (with k_e, x_e) in task-axis order and the
        mask over the task axes (bool (m,), read-only). ArgumentError naming force_axes for an axis the
        model does not have, or force_kp / force_kv for gains missing."""
        task_axes = tuple(model.task_axes)
        axes = self.force_axes
        unknown = [a for a in axes if a not in task_axes]
        if unknown:
            raise ArgumentError('force_axes', f'{unknown} not among the model\'s task axes {list(task_axes)}')
        missing = [name for name in GAIN_NAMES[:2] if axes and not getattr(self, name).size]
        if missing:
            raise ArgumentError(missing[0], f'expected {len(axes)} gains (one per force axis {list(axes)}), got none')
        ordered = tuple(a for a in task_axes if a in axes)
        order = [axes.index(a) for a in ordered]
        gains = {name: getattr(self, name)[order] for name in GAIN_NAMES if getattr(self, name).size}
        return dataclasses.replace(self, force_axes=ordered, k_e=self.k_e[order], x_e=self.x_e[order], **gains,
                                   mask=[a in axes for a in task_axes])


def gain_params(gains):
    """The force servo's parameters (force_kp, force_kv, force_ki) of ServoGains `gains`, one per force axis: what
    a law's parameters (ControllerConfig.law_params) take, e.g. robot_control.gains.design(...).gains(k)."""
    return {name: getattr(gains, name[len('force_'):]) for name in GAIN_NAMES}


#: the setup of a law without force: no force axes
NO_FORCE_TASK = ForceTask()
