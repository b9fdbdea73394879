#!/usr/bin/python3
"""Top entries of a `perf record` profile as Markdown tables: share per library, then per symbol.

    ONEDNN_JIT_PROFILE=2 perf record -F 999 -o P.data -- build/bin/handscs-train ...
    /usr/bin/python3 tools/study/perf_top.py P.data [ROWS]

ONEDNN_JIT_PROFILE=2 makes oneDNN write /tmp/perf-PID.map, so its JIT kernels (the GEMMs and
convolutions) get names; their entries at different addresses are summed by name here. Debian's
libtorch and libgomp are stripped: their samples show as one "unresolved" entry per library.
"""
import collections
import re
import subprocess
import sys


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    data = sys.argv[1]
    rows = int(sys.argv[2]) if len(sys.argv) > 2 else 14
    report = subprocess.run(['perf', 'report', '-i', data, '--sort', 'dso,symbol', '--stdio'],
                            capture_output=True, text=True, check=True).stdout
    per_library = collections.Counter()
    per_symbol = collections.Counter()
    line_format = re.compile(r'\s*([\d.]+)%\s+(\S+(?: tid \d+)?)\s+\[.\]\s+(.*?)\s*(?:-\s+-\s*)?$')
    for line in report.splitlines():
        match = line_format.match(line)
        if not match:
            continue
        share, library, symbol = float(match.group(1)), match.group(2), match.group(3)
        if library.startswith('[JIT]'):
            library = 'oneDNN JIT'
        symbol = re.sub(r'\(.*', '', symbol.replace('(anonymous namespace)::', ''))[:70]
        if symbol.startswith('0x'):
            symbol = 'unresolved (stripped library)'
        per_library[library] += share
        per_symbol[(library, symbol)] += share
    print('| library | share |\n|---|---|')
    for library, share in per_library.most_common(6):
        print(f'| {library} | {share:.1f}% |')
    print('\n| library | symbol | share |\n|---|---|---|')
    for (library, symbol), share in per_symbol.most_common(rows):
        print(f'| {library} | `{symbol}` | {share:.1f}% |')


if __name__ == '__main__':
    main()
