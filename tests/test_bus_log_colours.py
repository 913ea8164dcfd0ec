"""Log lines look like rcutils': colour by severity, stderr by default, stdout in a notebook."""

from __future__ import annotations

import io

import pytest

from robocourse.bus import Context
from robocourse.bus import logging as bus_logging
from robocourse.bus.logging import LoggingSeverity, LogRecord, console_line


class Tty(io.StringIO):
    def isatty(self):
        return True


def record(sev):
    return LogRecord(sev, "talker", "hello", 1_700_000_000_123_456_789)


def test_colours_match_rcutils_on_a_terminal(monkeypatch):
    monkeypatch.delenv("RCUTILS_COLORIZED_OUTPUT", raising=False)
    tty = Tty()
    assert console_line(record(LoggingSeverity.DEBUG), tty) == "\033[32m[DEBUG] [1700000000.123456789] [talker]: hello\033[0m"
    assert console_line(record(LoggingSeverity.INFO), tty) == "[INFO] [1700000000.123456789] [talker]: hello"
    assert console_line(record(LoggingSeverity.WARN), tty).startswith("\033[33m[WARN]")
    assert console_line(record(LoggingSeverity.ERROR), tty).startswith("\033[31m[ERROR]")
    assert console_line(record(LoggingSeverity.FATAL), tty).startswith("\033[31m[FATAL]")
    assert "\033" not in console_line(record(LoggingSeverity.ERROR), io.StringIO())   # a pipe or file: plain


def test_colour_and_stream_variables_are_honoured(monkeypatch, capsys):
    monkeypatch.setenv("RCUTILS_COLORIZED_OUTPUT", "1")
    assert console_line(record(LoggingSeverity.WARN), io.StringIO()).startswith("\033[33m")
    monkeypatch.setenv("RCUTILS_COLORIZED_OUTPUT", "0")
    assert "\033" not in console_line(record(LoggingSeverity.WARN), Tty())
    monkeypatch.setenv("RCUTILS_COLORIZED_OUTPUT", "yes")
    with pytest.raises(ValueError, match="RCUTILS_COLORIZED_OUTPUT='yes'.*1 or 0"):
        console_line(record(LoggingSeverity.WARN), Tty())
    monkeypatch.setenv("RCUTILS_COLORIZED_OUTPUT", "0")
    node = Context().create_node("talker")
    node.get_logger().info("to stderr by default")
    out = capsys.readouterr()
    assert "to stderr by default" in out.err and out.out == ""
    monkeypatch.setenv("RCUTILS_LOGGING_USE_STDOUT", "1")
    node.get_logger().warning("to stdout when asked")
    out = capsys.readouterr()
    assert "[WARN]" in out.out and "to stdout when asked" in out.out and out.err == ""


def test_in_a_notebook_info_goes_to_stdout_plain_and_errors_are_red(monkeypatch, capsys):
    """Jupyter paints all of stderr pink: in a kernel the lines go to stdout with rcutils' colours."""
    monkeypatch.delenv("RCUTILS_COLORIZED_OUTPUT", raising=False)
    monkeypatch.delenv("RCUTILS_LOGGING_USE_STDOUT", raising=False)
    monkeypatch.setattr(bus_logging, "_in_jupyter_kernel", lambda: True)
    log = Context().create_node("driver_node").get_logger()
    log.info("motors re-enabled")
    log.warning("no /cmd_vel for 210 ms: emergency stop")
    log.error("bad value")
    out = capsys.readouterr()
    assert out.err == ""
    lines = out.out.splitlines()
    assert lines[0].startswith("[INFO]") and "\033" not in lines[0]
    assert lines[1].startswith("\033[33m[WARN]") and lines[1].endswith("\033[0m")
    assert lines[2].startswith("\033[31m[ERROR]")


def test_a_real_kernel_shows_info_on_stdout_and_warn_in_yellow(tmp_path, monkeypatch):
    """Executed by a Jupyter kernel (what a student's notebook is): no log line lands on stderr."""
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    monkeypatch.delenv("RCUTILS_COLORIZED_OUTPUT", raising=False)
    monkeypatch.delenv("RCUTILS_LOGGING_USE_STDOUT", raising=False)
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell(
        "from robocourse.bus import Context\n"
        "log = Context().create_node('driver_node').get_logger()\n"
        "log.info('cmd_vel received again: motors re-enabled')\n"
        "log.warning('no /cmd_vel for 210 ms: emergency stop')")]
    nbclient.NotebookClient(nb, timeout=60, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}).execute()
    streams = [o for o in nb.cells[0].outputs if o["output_type"] == "stream"]
    assert streams and all(o["name"] == "stdout" for o in streams), streams
    text = "".join(o["text"] for o in streams)
    assert "[INFO]" in text and "\033[33m[WARN]" in text and "\033[31m" not in text
