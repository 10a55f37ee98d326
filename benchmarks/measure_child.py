"""Run one command and report its own peak RSS and CPU time, free of the caller's memory.

Linux starts a child's `ru_maxrss` at the resident size of the process that forked it, so a large
caller (a test session, a benchmark that already loaded numba) would count as the child's peak. This
small launcher forks the command instead and writes its exit code, peak RSS (bytes), CPU time
(user + system, seconds) and minor page faults to REPORT as JSON.

    python benchmarks/measure_child.py REPORT COMMAND [ARGUMENT ...]
"""

import json
import os
import subprocess
import sys

if __name__ == "__main__":
    child = subprocess.Popen(sys.argv[2:])
    _, status, usage = os.wait4(child.pid, 0)
    with open(sys.argv[1], "w") as report:
        json.dump({"exit_code": os.waitstatus_to_exitcode(status), "peak_bytes": usage.ru_maxrss * 1024,
                   "cpu_s": usage.ru_utime + usage.ru_stime, "minor_faults": usage.ru_minflt}, report)
