"""ROS parameter files (config/*.yaml) as flat dicts."""


def flatten(d, prefix=''):
    """{'a': {'b': 1}} -> {'a.b': 1}: the nested keys of a `ros__parameters` section as parameter names."""
    out = {}
    for k, v in d.items():
        if isinstance(v, dict):
            out.update(flatten(v, f'{prefix}{k}.'))
        else:
            out[f'{prefix}{k}'] = v
    return out
