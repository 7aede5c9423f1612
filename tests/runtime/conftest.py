"""Fixtures for the runtime tests."""

import pytest

from runtime_helpers import load_handmade


@pytest.fixture(scope="session")
def pendulum():
    return load_handmade("pendulum")


@pytest.fixture(scope="session")
def slider_crank():
    return load_handmade("slider_crank")
