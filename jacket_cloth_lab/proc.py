# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""What Linux's /proc says about a process's CPU time and the machine's stolen time."""

import os


def cpu_seconds(pid: int) -> float:
    """Return the CPU time (user and system) process ``pid`` has used, in seconds.

    :param pid: the process.
    """
    with open(f'/proc/{pid}/stat', encoding='ascii') as f:
        fields = f.read().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


def cpu_ticks() -> tuple[int, int]:
    """Return (steal, total) jiffies of all CPUs since boot, from /proc/stat; (0, 0) elsewhere."""
    try:
        with open('/proc/stat', encoding='ascii') as f:
            fields = [int(v) for v in f.readline().split()[1:]]
    except (OSError, ValueError):
        return 0, 0
    return (fields[7] if len(fields) > 7 else 0), sum(fields[:8])
