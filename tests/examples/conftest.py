"""Fixtures for the end-to-end tests."""

import pytest

from e2e import run_cli


@pytest.fixture
def cli():
    return run_cli
