"""Child processes that die with their parent: the loader's workers and `study`'s `simgen generate`.

A parent killed with SIGKILL cannot stop its children, and a loader worker blocked on a full pipe
never notices it is gone; the kernel can stop them: Linux's PR_SET_PDEATHSIG has it SIGKILL the child
when the thread that started it ends (here always the main thread, which lives as long as its
process).
"""

from __future__ import annotations

import ctypes
import os
import signal

PR_SET_PDEATHSIG = 1  # <linux/prctl.h>
# Resolved here, in the parent: after a fork of a threaded process the child should not dlopen.
_PRCTL = ctypes.CDLL(None, use_errno=True).prctl


def die_with_parent(parent: int) -> None:
    """In a child process: be killed (SIGKILL) when it ends; exit at once if it has already.

    Args:
        parent: the pid of the process that started this one, as that process saw it (os.getpid()).
    """
    if _PRCTL(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) != 0:
        raise OSError(ctypes.get_errno(), "prctl(PR_SET_PDEATHSIG) failed")
    if os.getppid() != parent:  # it died before the prctl: no signal will come
        os._exit(1)
