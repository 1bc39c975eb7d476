#!/usr/bin/env python3
"""Runs a command and writes "wall user sys" seconds to a file, as /usr/bin/time -f "%e %U %S"
does, but to the microsecond (wall from a monotonic clock around fork and wait, CPU from the
child's rusage by wait4()): /usr/bin/time's hundredths are 12 % of a 0.08 s process.
  bench/timed.py TIME_FILE COMMAND ARGS...   (the command's stdout and stderr pass through)"""
import os, subprocess, sys, time

out, command = sys.argv[1], sys.argv[2:]
start = time.perf_counter()
child = subprocess.Popen(command)
_, status, usage = os.wait4(child.pid, 0)
wall = time.perf_counter() - start
with open(out, "w") as f:
    f.write(f"{wall:.6f} {usage.ru_utime:.6f} {usage.ru_stime:.6f}\n")
sys.exit(os.waitstatus_to_exitcode(status))
