"""The CI hypothesis profile is reproducible: derandomized, no example database, no deadline (tests/conftest.py)."""

from __future__ import annotations

from hypothesis import settings


def test_ci_profile_is_derandomized_without_a_replay_database() -> None:
    ci = settings.get_profile("ci")
    assert ci.derandomize and ci.database is None and ci.deadline is None
