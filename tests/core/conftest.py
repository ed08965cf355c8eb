"""Fixtures of the core tests: a real NASA blade and small analytic meshes (built by
:mod:`tests.support.blades`)."""

from __future__ import annotations

import pytest

from tests.support.blades import nasa_blade, tube_blade


@pytest.fixture(scope="session")
def rotor37():
    return nasa_blade("rotor37")


@pytest.fixture
def tube():
    return tube_blade()


@pytest.fixture
def make_tube():
    """The :func:`~tests.support.blades.tube_blade` factory, for tests that need other
    parameters."""
    return tube_blade
