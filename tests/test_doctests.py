"""Docstring examples in engine/ and service/ run as tests, so they cannot drift."""

from __future__ import annotations

import doctest
import importlib
import pkgutil

import pytest

import engine
import service


def _modules() -> list[str]:
    names = []
    for pkg in (engine, service):
        names.append(pkg.__name__)
        for info in pkgutil.walk_packages(pkg.__path__, prefix=f"{pkg.__name__}."):
            names.append(info.name)
    return names


@pytest.mark.parametrize("name", _modules())
def test_docstring_examples(name: str) -> None:
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0
