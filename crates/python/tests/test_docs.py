"""The docstrings' examples run and give what they show."""

import doctest

import octowrap


def test_docstring_examples():
    result = doctest.testmod(octowrap, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted >= 10
    assert result.failed == 0
