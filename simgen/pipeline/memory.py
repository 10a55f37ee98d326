"""Memory settings of a run: Arrow's allocator, and handing freed memory back to the OS after each job."""

from __future__ import annotations

import ctypes
import gc
import sys

#: Arrow's pool: jemalloc where pyarrow has it (its Linux wheels), else the C heap. The default
#: (mimalloc in pyarrow 26) keeps what it frees for reuse and the C heap fragments while shards are
#: read back; a 6,000-frame clip's join in a fresh process peaks at 447 (mimalloc), 429 (C heap) and
#: 403 MiB (jemalloc). Arrow reads the variable when pyarrow is imported: `simgen generate` sets it
#: before, for itself, its workers and its Ray tasks.
ARROW_ENVIRONMENT = {"ARROW_DEFAULT_MEMORY_POOL": "jemalloc" if sys.platform.startswith("linux") else "system"}
_MALLOC_TRIM = getattr(ctypes.CDLL(None), "malloc_trim", None)  # glibc's; None elsewhere


def release_memory() -> None:
    """Hand what the last job freed back to the OS (Arrow's pool, the C heap), so that a process's
    peak is its largest job's rather than that job plus what earlier ones left in the allocators
    (a clip's capture, then its shards, then their assembly)."""
    import pyarrow

    gc.collect()
    pyarrow.default_memory_pool().release_unused()
    if _MALLOC_TRIM is not None:
        _MALLOC_TRIM(0)
