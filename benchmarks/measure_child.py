"""Run one command and report its own peak RSS and CPU time, free of the caller's memory.

Linux starts a child's `ru_maxrss` at the resident size of the process that forked it, so a large
caller (a test session, a benchmark that already loaded numba) would count as the child's peak. This
small launcher forks the command instead and writes `exit_code peak_bytes cpu_seconds` to REPORT.

    python benchmarks/measure_child.py REPORT COMMAND [ARGUMENT ...]
"""

import os
import subprocess
import sys

if __name__ == "__main__":
    child = subprocess.Popen(sys.argv[2:])
    _, status, usage = os.wait4(child.pid, 0)
    with open(sys.argv[1], "w") as report:
        report.write(f"{os.waitstatus_to_exitcode(status)} {usage.ru_maxrss * 1024} {usage.ru_utime + usage.ru_stime}")
