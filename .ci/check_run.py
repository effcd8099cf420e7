"""Read a pytest JUnit XML report: print what ran and every skip with its reason; fail when a test
skipped for a reason not in .ci/allowed_skips.txt, or when nothing passed (``--require-pass``).

    python .ci/check_run.py REPORT.xml LABEL [--require-pass]
"""
from __future__ import annotations

import sys
import xml.etree.ElementTree as ET
from pathlib import Path

ALLOWED = Path(__file__).with_name("allowed_skips.txt")


def allowed_reasons(path: Path = ALLOWED) -> list[str]:
    lines = (x.split("::", 1)[0].strip() for x in path.read_text().splitlines())
    return [x for x in lines if x and not x.startswith("#")]


def skips(report: Path) -> tuple[dict[str, int], list[tuple[str, str]]]:
    """(counts of tests, skipped, failures, errors), [(test id, skip message)]."""
    root = ET.parse(report).getroot()
    suites = [root] if root.tag == "testsuite" else root.findall("testsuite")
    count = {k: sum(int(s.get(k, 0)) for s in suites) for k in ("tests", "skipped", "failures",
                                                                  "errors")}
    out = []
    for case in root.iter("testcase"):
        for sk in case.findall("skipped"):
            out.append((f"{case.get('classname')}::{case.get('name')}", sk.get("message", "")))
    return count, out


def main(argv: list[str]) -> int:
    report, label = Path(argv[0]), argv[1]
    count, skipped = skips(report)
    ran = count["tests"] - count["skipped"] - count["failures"] - count["errors"]
    print(
        f"ci: {label} tests: {count['tests']} collected, {ran} passed, {count['skipped']} skipped"
    )
    allowed = allowed_reasons()
    refused = []
    for test, message in skipped:
        ok = any(a in message for a in allowed)
        print(f"ci:   skipped {test}: {message}" + ("" if ok else "  <- not an allowed skip"))
        if not ok:
            refused.append(test)
    if refused:
        print(f"ci: FAIL: {len(refused)} {label} test(s) skipped for a reason not in "
              f"{ALLOWED.relative_to(ALLOWED.parents[1])}")
        return 1
    if "--require-pass" in argv and ran <= 0:
        print(f"ci: FAIL: the {label} test run passed no test at all")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
