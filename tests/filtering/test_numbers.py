"""Numbers written back: the original's decimals, one more only where the correction needs it."""

import numpy as np

from calibrator.languages import numbers


def test_one_more_decimal_only_where_rounding_would_lose_the_correction():
    tokens = [["1234.5", "+5", "-0.000", "1E3", "12.3456"]]
    old = np.array([[1234.5, 5.0, 0.0, 1000.0, 12.3456]])
    new = np.array([[1234.54, 5.3, -0.0001, 1000.0, 12.34571]])
    out = numbers.write_many(tokens, old, new, ("mm", "mm", "mm", "mm", "deg"))
    assert out == [["1234.54", "+5.3", "-0.000", "1E3", "12.3457"]]
    near = numbers.write_many(
        tokens, old, np.array([[1234.503, 5.004, 0.0, 1000.0, 12.3456]]), ("mm",) * 4 + ("deg",)
    )
    assert near == tokens  # within the resolution: the original text stays


def test_write_many_agrees_with_write():
    rng = np.random.default_rng(1)
    old = np.round(rng.uniform(-2000, 2000, (50, 3)), 2)
    tokens = [[f"{v:.2f}" for v in row] for row in old]
    new = old + rng.normal(0, 0.05, old.shape)
    many = numbers.write_many(tokens, old, new, ("mm",) * 3)
    one = [
        [numbers.write(t, v, "mm") for t, v in zip(r, n, strict=True)]
        for r, n in zip(tokens, new, strict=True)
    ]
    assert many == one


def test_the_possessive_plain_grammar_matches_what_the_plain_one_matches():
    import re

    possessive = re.compile(numbers.PLAIN_POSSESSIVE)
    digits = ["", "0", "7", "12", "1" * 20, "1" * 21]
    tokens = [
        sign + whole + dot + frac
        for sign in ("", "+", "-", "+-")
        for whole in digits
        for dot in ("", ".", "..")
        for frac in digits
    ]
    tokens += ["1e3", ".", "-.", "1.2.3", " 1", "1 "]
    for token in tokens:
        assert bool(possessive.fullmatch(token)) == bool(numbers.PLAIN.fullmatch(token)), token
