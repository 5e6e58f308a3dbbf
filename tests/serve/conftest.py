"""The session's planning service (tests/serve/serving.py starts it)."""

from __future__ import annotations

import pytest

pytest.importorskip("fastapi")  # the serve extra

from serving import TOKEN, start  # noqa: E402


@pytest.fixture(scope="session")
def service(tmp_path_factory):
    """One worker, a queue of one, a token: what the answer, input and fault tests share. A test
    that kills the worker waits for its replacement before it ends."""
    s = start(tmp_path_factory.mktemp("service"), "--workers", "1", "--queue", "1", token=TOKEN)
    yield s
    assert s.stop() == 0
