"""Robot models: the lecture's closed forms and URDF robots through Pinocchio."""
from robot_control.models.base import RobotModel
from robot_control.models.closed_form import CLOSED_FORM


def make_model(name, **params):
    """A closed-form model by name with its physical parameters (SI), e.g. make_model('polar_two_link', m=2.0)."""
    try:
        cls = CLOSED_FORM[name]
    except KeyError:
        raise ValueError(f'model: unknown closed-form model {name!r}; expected one of {sorted(CLOSED_FORM)}') from None
    try:
        return cls(**params)
    except TypeError as exc:
        raise ValueError(f'model {name!r}: bad parameters {sorted(params)}: {exc}') from None


__all__ = ['RobotModel', 'CLOSED_FORM', 'make_model']
