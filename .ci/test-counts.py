#!/usr/bin/env python3
"""Counts the tests a run ran, from its output: every `test result:` line of `cargo test` (one
per test binary and per doc-test run) and pytest's closing line. So the README states no count
that can go stale: .ci/run prints these after ./test.sh, and anyone can count their own run.

    ./test.sh 2>&1 | tee test-output.txt; python3 .ci/test-counts.py test-output.txt
    cargo test -p sdfmo-format 2>&1 | python3 .ci/test-counts.py -

Exits 1 when the output holds no `cargo test` result at all (a run that tested nothing).
"""

import re
import sys

CARGO = re.compile(
    r"^test result: \w+\. (\d+) passed; (\d+) failed; (\d+) ignored; (\d+) measured; (\d+) filtered out"
)
# pytest's summary: "82 passed, 2 skipped, 1 warning in 18.20s" (with or without `=` around it).
PYTEST = re.compile(r"^=*\s*(\d+ (?:passed|failed)\b.*) in [\d.]+s\b")
PYTEST_COUNT = re.compile(r"(\d+) (passed|failed|skipped|errors?|xfailed|xpassed|deselected)")


def count(lines):
    """Returns the cargo totals (passed, failed, ignored, runs) and pytest's counts by outcome."""
    cargo = [0, 0, 0, 0]
    pytest = {}
    for line in lines:
        line = line.strip()
        m = CARGO.match(line)
        if m:
            passed, failed, ignored = (int(m.group(i)) for i in (1, 2, 3))
            cargo[0] += passed
            cargo[1] += failed
            cargo[2] += ignored
            cargo[3] += 1
            continue
        m = PYTEST.match(line)
        if m:
            # The last summary wins: one pytest run per log.
            pytest = {k.rstrip("s") if k.startswith("error") else k: int(n)
                      for n, k in PYTEST_COUNT.findall(m.group(1))}
    return cargo, pytest


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: test-counts.py LOG (or - for standard input)")
    src = sys.stdin if sys.argv[1] == "-" else open(sys.argv[1], encoding="utf-8", errors="replace")
    with src:
        (passed, failed, ignored, runs), pytest = count(src)
    if runs == 0:
        print("test-counts: no `cargo test` result in the output", file=sys.stderr)
        return 1
    print(f"test-counts: cargo test ran {passed + failed} tests in {runs} runs (test binaries "
          f"and doc-tests): {passed} passed, {failed} failed; {ignored} ignored")
    if pytest:
        ran = pytest.get("passed", 0) + pytest.get("failed", 0)
        rest = ", ".join(f"{n} {k}" for k, n in pytest.items() if k not in ("passed", "failed"))
        print(f"test-counts: pytest ran {ran} tests: {pytest.get('passed', 0)} passed, "
              f"{pytest.get('failed', 0)} failed{'; ' + rest if rest else ''}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
