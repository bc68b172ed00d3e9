"""A hung test ends the run with every thread's stack, under the repository's own pytest.ini (faulthandler's
watchdog), instead of holding CI until its time runs out: a CI run once timed out with no word of where."""
import configparser
import pathlib
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[2]


def test_the_watchdog_is_on_and_above_the_slowest_test():
    ini = configparser.ConfigParser()
    ini.read(ROOT / "pytest.ini")
    assert ini.getboolean("pytest", "faulthandler_exit_on_timeout")
    assert 300 <= float(ini["pytest"]["faulthandler_timeout"]) <= 900  # the slowest test takes about a minute


def test_a_hung_test_is_ended_and_says_where(tmp_path):
    (tmp_path / "test_stuck.py").write_text("import time\n\ndef test_waits_forever():\n    time.sleep(600)\n")
    started = time.monotonic()
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-c", str(ROOT / "pytest.ini"),
                          "--rootdir", str(tmp_path), "-o", "faulthandler_timeout=2", str(tmp_path / "test_stuck.py")],
                         stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=120)
    assert time.monotonic() - started < 60 and run.returncode != 0
    assert "Timeout" in run.stderr and "test_waits_forever" in run.stderr and "test_stuck.py" in run.stderr
