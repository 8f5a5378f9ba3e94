"""Robot models: the lecture's closed forms and URDF robots through Pinocchio.

Pinocchio is imported only when a URDF model is asked for (UrdfModel, resolve_urdf,
make_model('urdf', ...), for_scenario of a URDF scenario).
"""
import numpy as np

from robot_control.validation import ArgumentError
from robot_control import units, validation
from robot_control.models.base import RobotModel
from robot_control.models.closed_form import CLOSED_FORM


def make_model(name, **params):
    """A model by name with its parameters.

    Closed form with its physical parameters (SI), e.g. make_model('polar_two_link', m=2.0);
    or make_model('urdf', urdf=..., joints=..., tip=..., q_locked=..., gravity=...) -> UrdfModel.
    """
    if name == 'urdf':
        from robot_control.models.urdf_model import UrdfModel
        if 'urdf' not in params:
            raise ArgumentError("urdf", "make_model('urdf', ...) needs urdf=<file path, XML text or shipped name>")
        try:
            return UrdfModel(**params)
        except TypeError as exc:
            raise ValueError(f"model 'urdf': bad parameters {sorted(params)}: {exc}") from None
    try:
        cls = CLOSED_FORM[name]
    except KeyError:
        raise ArgumentError('model', f'unknown closed-form model {name!r}; expected one of {sorted(CLOSED_FORM)} '
                         "or 'urdf'") from None
    try:
        return cls(**params)
    except TypeError as exc:
        raise ValueError(f'model {name!r}: bad parameters {sorted(params)}: {exc}') from None


def for_scenario(scenario, **overrides):
    """The controller's default model of `scenario` (a Scenario or its name), with parameter overrides.

    Closed-form scenarios: make_model(scenario.model, **{**scenario.params, **overrides}).
    URDF scenarios: UrdfModel(scenario.urdf, joints=scenario.joints, tip=scenario.tip), where
    overrides may set urdf, joints, tip, q_locked, task_space, payload, and gravity (m/s^2
    downwards along world z, or a 3-vector); scenario.params['gravity'], if any, is the default.
    """
    from robot_control import scenarios
    if isinstance(scenario, str):
        scenario = scenarios.get(scenario)
    elif not isinstance(scenario, scenarios.Scenario):
        raise ArgumentError('scenario', f'expected a Scenario or a scenario name, got {type(scenario).__name__}')
    if scenario.model != 'urdf':
        return make_model(scenario.model, **{**scenario.params, **overrides})
    from robot_control.models.urdf_model import UrdfModel, resolve_urdf
    allowed = {'urdf', 'joints', 'tip', 'q_locked', 'gravity', 'task_space', 'payload'}
    unknown = sorted(set(overrides) - allowed)
    if unknown:
        raise ArgumentError('overrides', f'unknown {unknown} for URDF scenario {scenario.name!r}; '
                         f'expected some of {sorted(allowed)}')
    args = {'urdf': scenario.urdf, 'joints': scenario.joints, 'tip': scenario.tip or None,
            'gravity': scenario.params.get('gravity', units.GRAVITY), **overrides}
    if np.ndim(args['gravity']) == 0:
        args['gravity'] = (0.0, 0.0, -validation.scalar('gravity', args['gravity']))
    if isinstance(args['urdf'], str) and not args['urdf'].lstrip().startswith('<'):
        args['urdf'] = resolve_urdf(args['urdf'])
    return UrdfModel(**args)


def __getattr__(name):
    """Lazy access to the Pinocchio-backed names: models.UrdfModel, models.resolve_urdf."""
    if name in ('UrdfModel', 'resolve_urdf'):
        from robot_control.models import urdf_model
        return getattr(urdf_model, name)
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')


__all__ = ['RobotModel', 'CLOSED_FORM', 'make_model', 'for_scenario', 'UrdfModel', 'resolve_urdf']
