"""How the suite is split: the units of work of scripts/test.sh's two pytest-xdist
workers (--dist loadgroup).  A pytest plugin: tests/conftest.py imports its hook."""

from __future__ import annotations

import pytest

@pytest.hookimpl(tryfirst=True)  # before pytest-xdist reads the groups into the test ids
def pytest_collection_modifyitems(config, items):
    """Scheduling on pytest-xdist's workers (scripts/test.sh: --dist loadgroup): a test that uses a module-scoped fixture runs
    on the worker of its module's other such tests, so that the fixture is computed
    once, unless it names its own xdist_group (the hidden-effect diagnoses of
    test_diagnose.py: one group per effect); every other test is a unit of work of its
    own.  Without loadgroup the groups do nothing."""
    for item in items:
        if item.get_closest_marker("xdist_group"):
            continue
        # the fixtures' scopes: pytest has no public API for them (a doctest has none)
        fixtures = getattr(item, "_fixtureinfo", None)
        defs = fixtures.name2fixturedefs.values() if fixtures else ()
        if any(d and d[-1].scope in ("module", "class") for d in defs):
            item.add_marker(pytest.mark.xdist_group(item.nodeid.split("::")[0]))
