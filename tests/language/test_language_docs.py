"""The documentation examples of the language package run as written."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = ["samplehd.language", "samplehd.language.descriptions", "samplehd.language.executor"]


@pytest.mark.parametrize("name", MODULES)
def test_doc_examples(name: str) -> None:
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.failed == 0
