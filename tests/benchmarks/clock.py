"""A stopwatch shared by run.py and peers.py (they run in different interpreters).

Standard library only: peers.py runs in the peers' environment, where the project is
not installed. Both scripts find this module next to them (sys.path[0]).
"""

from __future__ import annotations

import gc
import multiprocessing
import time
from typing import Any


class Clock:
    """Wall-clock and CPU time (of this process) since creation, in ms."""

    def __init__(self) -> None:
        gc.collect()  # the same for every tool: no garbage left over from the last run
        self.wall = time.perf_counter()
        self.cpu = time.process_time()

    def stop(self) -> tuple[float, float]:
        """Return (wall ms, CPU ms) since creation."""
        return (time.perf_counter() - self.wall) * 1e3, (
            time.process_time() - self.cpu
        ) * 1e3


class StealMeter:
    """Share of this machine's CPU time the hypervisor gave to others since creation.

    On a virtual machine whose host is busy, the guest's CPUs stand still for a while
    now and then ("steal" time in /proc/stat); every wall-clock latency measured then is
    longer than the code's. Benchmarks print it next to their percentiles. None where
    /proc/stat is not available.
    """

    def __init__(self) -> None:
        self.start = _cpu_times()

    def stop(self) -> float | None:
        """Return steal / all CPU time since creation, as a fraction (or None)."""
        end = _cpu_times()
        if self.start is None or end is None:
            return None
        total = sum(end) - sum(self.start)
        if total <= 0:
            return 0.0
        return (end[7] - self.start[7]) / total


def busy_cpu_s() -> float | None:
    """CPU seconds every core of the machine has been busy since boot (None without
    /proc/stat): user, nice, system, interrupts and steal; not idle, not waiting for I/O."""
    times = _cpu_times()
    if times is None:
        return None
    return (sum(times) - times[3] - times[4]) / 100.0


def _cpu_times() -> list[int] | None:
    try:
        with open("/proc/stat", encoding="ascii") as stat:
            fields = stat.readline().split()
    except OSError:
        return None
    if not fields or fields[0] != "cpu" or len(fields) < 9:
        return None
    return [int(v) for v in fields[1:9]]


def spread(target_ms: float = 12.0, samples: int = 150) -> tuple[float, float]:
    """Return p50 and p95 [ms] of one fixed piece of work done ``samples`` times.

    The same work every time (sorting the same list; about ``target_ms`` once
    calibrated), so any spread is the machine's: on a shared virtual machine a fixed
    12 ms of work has been seen to take 12 to 17 ms at its 95th percentile. Benchmarks
    print it beside their own p95, which cannot be steadier than this.
    """
    data = [((k * 7919) % 10007) / 10007.0 for k in range(20000)]

    def work(rounds: int) -> float:
        return sum(sorted(data)[k % 100] for k in range(rounds))

    start = time.perf_counter()
    work(3)
    rounds = max(1, round(3 * target_ms / ((time.perf_counter() - start) * 1e3)))
    times = []
    for _ in range(samples):
        start = time.perf_counter()
        work(rounds)
        times.append((time.perf_counter() - start) * 1e3)
    times.sort()
    return times[len(times) // 2], times[min(len(times) - 1, int(0.95 * len(times)))]


def in_fresh_process(target: Any, args: tuple, timeout: float) -> dict:
    """Run ``target(*args, send)`` in a spawned process; return what it sends.

    Cold work: nothing the caller cached answers, and the child's ``ru_maxrss`` is its
    own. A child that sends nothing within ``timeout`` s is killed and reported so.
    """
    ctx = multiprocessing.get_context("spawn")
    receive, send = ctx.Pipe(duplex=False)
    child = ctx.Process(target=target, args=(*args, send))
    child.start()
    answer = receive.recv() if receive.poll(timeout) else None
    child.join(5 if answer else 0)
    if child.is_alive():
        child.kill()
        child.join()
    return answer or {"error": f"no answer within {timeout:g} s (killed)"}
