"""Test tiers (pyproject.toml: the default tier leaves out tests marked ``slow``).

A sweep over every preset or target keeps a few representative cases in the default tier and
runs the rest only in the slow tier (``bash .ci/run``, ``pytest -m slow``).
"""
from __future__ import annotations

import pytest


def quick_few(values, quick) -> list:
    """``values`` as pytest parameters: those in ``quick`` run in the default tier, the others
    carry the ``slow`` mark."""
    quick = set(quick)
    missing = quick - set(values)
    assert not missing, f"quick cases not among the values: {sorted(missing)}"
    return [v if v in quick else pytest.param(v, marks=pytest.mark.slow) for v in values]
