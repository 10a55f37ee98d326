"""The tests' pytest fixtures; what they import lives in tests/support/."""

from __future__ import annotations

import pytest

from tests.support import MOTION_FIXTURE


@pytest.fixture(scope="session")
def motion_clip():
    """The committed clip captured from the real engine by `simgen capture` (see tests/fixtures/README.md)."""
    from simgen.motion.clip_io import read_clip

    return read_clip(MOTION_FIXTURE)
