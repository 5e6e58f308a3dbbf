"""Recent keeps the last `size` values by key: the least recently used goes first, a value asked
again is not made again, and a make that raises keeps nothing."""

from __future__ import annotations

import pytest

from judgeopt.recent import Recent


def test_the_least_recently_used_goes_first_and_a_kept_value_is_not_made_again():
    made = []
    recent = Recent(2)

    def make(key):
        return lambda: made.append(key) or key.upper()

    assert recent.get_or_make("a", make("a")) == "A"
    recent.get_or_make("b", make("b"))
    assert recent.get_or_make("a", make("a")) == "A" and made == ["a", "b"]  # kept, and now the most recent
    recent.get_or_make("c", make("c"))  # drops b, the least recently used
    assert list(recent) == ["a", "c"]
    recent.get_or_make("b", make("b"))
    assert made == ["a", "b", "c", "b"] and list(recent) == ["c", "b"]


def test_a_make_that_raises_keeps_nothing():
    recent = Recent(2)
    with pytest.raises(ValueError):
        recent.get_or_make("x", lambda: (_ for _ in ()).throw(ValueError("bad request")))
    assert "x" not in recent and len(recent) == 0
