"""Fixtures of the simulator's tests."""
import pytest

from sim_bridge.engines import ENGINES, make_world as make_engine_world
from sim_bridge.world import World


@pytest.fixture
def make_world():
    """World factory (PyBullet) whose worlds are closed after the test."""
    worlds = []

    def factory(*args, **kwargs):
        worlds.append(World(*args, **kwargs))
        return worlds[-1]
    yield factory
    for w in worlds:
        w.close()


@pytest.fixture(params=ENGINES)
def engine(request):
    """The engine name; every test using it runs on each engine."""
    return request.param


@pytest.fixture
def world_on(engine):
    """World factory on the fixture's engine; its worlds are closed after the test."""
    worlds = []

    def factory(*args, **kwargs):
        worlds.append(make_engine_world(engine, *args, **kwargs))
        return worlds[-1]
    yield factory
    for w in worlds:
        w.close()
