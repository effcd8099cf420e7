""".ci/check_run.py, which .ci/run calls on each suite's JUnit report: a planted skip whose reason
is not in .ci/allowed_skips.txt fails CI; an allowed one and a clean run pass."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _report(tmp_path: Path, *cases: str) -> Path:
    path = tmp_path / "report.xml"
    skipped = sum("<skipped" in c for c in cases)
    path.write_text(f'<testsuites><testsuite name="pytest" tests="{len(cases)}" '
                    f'skipped="{skipped}" failures="0" errors="0">' + "".join(cases)
                    + "</testsuite></testsuites>")
    return path


def _check(report: Path, *flags: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(ROOT / ".ci" / "check_run.py"), str(report), "fast",
                           *flags], capture_output=True, text=True, timeout=60)


PASSED = '<testcase classname="tests.test_x" name="test_ok"/>'


def test_a_skip_not_in_the_allowed_list_fails_ci(tmp_path):
    planted = ('<testcase classname="tests.test_x" name="test_y"><skipped type="pytest.skip" '
               'message="could not import \'orthoglide_ident.nowhere\'"/></testcase>')
    run = _check(_report(tmp_path, PASSED, planted))
    assert run.returncode == 1, run.stdout
    assert "tests.test_x::test_y" in run.stdout and "not an allowed skip" in run.stdout


def test_an_allowed_skip_passes_and_is_printed_with_its_reason(tmp_path):
    allowed = ('<testcase classname="tests.bags.test_mcap_cli" name="test_doctor"><skipped '
               'message="the mcap CLI is not installed"/></testcase>')
    run = _check(_report(tmp_path, PASSED, allowed), "--require-pass")
    assert run.returncode == 0, run.stdout
    assert (
        "skipped tests.bags.test_mcap_cli::test_doctor: the mcap CLI is not installed" in run.stdout
    )


def test_a_run_that_passed_nothing_fails_when_a_pass_is_required(tmp_path):
    allowed = ('<testcase classname="t" name="a"><skipped message="the mcap CLI is not installed"/>'
               '</testcase>')
    assert _check(_report(tmp_path, allowed), "--require-pass").returncode == 1
    assert _check(_report(tmp_path, allowed)).returncode == 0
