"""Fixtures of the simulator's tests."""
import pytest

from sim_bridge.world import World


@pytest.fixture
def make_world():
    """World factory whose worlds are closed after the test."""
    worlds = []

    def factory(*args, **kwargs):
        worlds.append(World(*args, **kwargs))
        return worlds[-1]
    yield factory
    for w in worlds:
        w.close()
