"""The realism profiles (config/realism/<scenario>_typical.yaml) as bridge parameter values, for tests."""
import os

import yaml

from support.param_files import flatten

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
#: the payload of the identification tests and the demo's payload experiments: kg, m in the tip frame
PAYLOAD = {'payload.mass': 2.0, 'payload.com': [0.0, 0.0, 0.05]}


def typical_profile(scenario, mass_errors=True):
    """{name: value} of config/realism/<scenario>_typical.yaml's bridge parameters; without its link-mass
    and inertia errors (sim_params.mass_scale, inertia_scale) unless mass_errors."""
    with open(os.path.join(ROOT, 'config', 'realism', f'{scenario}_typical.yaml')) as f:
        values = flatten(yaml.safe_load(f)['/**/sim_bridge']['ros__parameters'])
    if not mass_errors:
        del values['sim_params.mass_scale'], values['sim_params.inertia_scale']
    return values
