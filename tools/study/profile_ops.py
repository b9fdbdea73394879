#!/usr/bin/env python3
"""Self time per op in a LibTorch op trace (handscs-bench-model --profile-ops TRACE).

Usage: tools/study/profile_ops.py TRACE_<count>.json [--steps N] [--top 25]

A trace event's self time is its duration minus that of the events nested directly inside it on
the same thread; the table lists ms per step (total / N) and calls per step, largest first.

Read small ops' times with care: under LibTorch 1.13's legacy profiler a [10k, 256] bf16 ReLU
backward shows 0.80 ms a call against 0.18-0.23 ms timed with a wall clock (docs/BENCHMARKS.md). Large GEMMs are reported near their wall time; time a candidate alone before
acting on its profile entry.
"""
import argparse
import collections
import json


def self_times(events):
    """(name, self_us) of every complete event, nesting read per thread from start and end."""
    by_thread = collections.defaultdict(list)
    for e in events:
        if e.get("ph") == "X" and "dur" in e:
            by_thread[e.get("tid")].append(e)
    for thread_events in by_thread.values():
        # Parents first: earlier start, and the longer event at an equal start.
        thread_events.sort(key=lambda e: (float(e["ts"]), -float(e["dur"])))
        stack = []  # [end, event, child_us]
        for e in thread_events:
            start, dur = float(e["ts"]), float(e["dur"])
            while stack and stack[-1][0] <= start:
                end, done, child = stack.pop()
                yield done["name"], float(done["dur"]) - child
            if stack:
                stack[-1][2] += dur
            stack.append([start + dur, e, 0.0])
        while stack:
            end, done, child = stack.pop()
            yield done["name"], float(done["dur"]) - child


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("trace")
    parser.add_argument("--steps", type=int, default=1, help="steps in the trace (--repeats)")
    parser.add_argument("--top", type=int, default=25)
    args = parser.parse_args()
    with open(args.trace) as f:
        data = json.load(f)
    events = data["traceEvents"] if isinstance(data, dict) else data
    total = collections.defaultdict(float)
    calls = collections.Counter()
    for name, us in self_times(events):
        total[name] += us
        calls[name] += 1
    grand = sum(total.values())
    print(f"| op | self ms / step | calls / step | share |")
    print(f"|---|---|---|---|")
    for name, us in sorted(total.items(), key=lambda kv: -kv[1])[: args.top]:
        print(f"| {name} | {us / 1000 / args.steps:.3f} | {calls[name] / args.steps:.0f} | "
              f"{100 * us / grand:.1f}% |")
    print(f"| (all) | {grand / 1000 / args.steps:.3f} | {sum(calls.values()) / args.steps:.0f} | |")


if __name__ == "__main__":
    main()
