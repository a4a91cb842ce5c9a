"""The command line: exit codes and messages."""

import subprocess
import sys


def run(*args):
    return subprocess.run([sys.executable, "-m", "exoleg.cli", *args], capture_output=True,
                          text=True)


def test_validate_passes_and_prints_table():
    r = run("validate", "--quick")
    assert r.returncode == 0, r.stdout + r.stderr
    assert "M vs Appendix B" in r.stdout and "0 failed" in r.stdout


def test_bad_option_exits_2():
    r = run("validate", "--bogus")
    assert r.returncode == 2 and "unrecognized arguments" in r.stderr
