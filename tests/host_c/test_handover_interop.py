"""The port hand-over record of the C library (host/c/port/handover.c) and of the Python library
(host/urb/managers/handover.py) are the same file: the same name for the same port (relative paths,
"..", "//" included), the same directory rules, and each reads what the other writes (a C process
after a Python one on the same port, and the other way round)."""

from __future__ import annotations

import ctypes
import os
from pathlib import Path

import pytest

from test_differential import lib
from urb.managers.handover import AHEAD_NS, MAX_WAIT_NS, PortHandover
from urb.managers.rs232_core import PLACEHOLDER_NS

MS = 1_000_000


def c_path(port: str, directory: str | None) -> str:
    out = ctypes.create_string_buffer(4096)
    f = lib().shim_handover_path
    f.restype, f.argtypes = ctypes.c_int, [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_char_p, ctypes.c_int]
    assert f(port.encode(), directory.encode() if directory else None, out, 4096) == 0
    return out.value.decode()


def c_call(name: str, port: str, directory: Path, *times: int) -> int:
    f = getattr(lib(), name)
    f.restype = ctypes.c_longlong if name == "shim_handover_until" else ctypes.c_int
    f.argtypes = [ctypes.c_char_p, ctypes.c_char_p] + [ctypes.c_longlong] * len(times)
    return int(f(port.encode(), str(directory).encode(), *times))


def c_now() -> int:
    f = lib().shim_now
    f.restype = ctypes.c_longlong
    return int(f())


@pytest.mark.parametrize("port", ["/dev/ttyUSB0", "/tmp/urb0", "//tmp/./x/../urb1/", "relative/port", "../up/a.b",
                                  "/dev/serial/by-id/usb-FTDI_FT232R-if00-port0"])
def test_the_same_port_gives_the_same_record(port: str, tmp_path: Path) -> None:
    assert c_path(port, str(tmp_path)) == str(PortHandover(port, tmp_path).path)


@pytest.mark.parametrize("env", [{"URB_STATE_DIR": "/st"}, {"XDG_RUNTIME_DIR": "/run/user/1"}, {"TMPDIR": "/var/t"}])
def test_the_same_state_directory(env: dict[str, str], monkeypatch: pytest.MonkeyPatch) -> None:
    import tempfile

    for var in ("URB_STATE_DIR", "XDG_RUNTIME_DIR", "TMPDIR", "TEMP", "TMP"):
        monkeypatch.delenv(var, raising=False)
    for k, v in env.items():
        monkeypatch.setenv(k, v)
    monkeypatch.setattr(tempfile, "tempdir", None)  # gettempdir() caches its first answer
    if "TMPDIR" in env:
        monkeypatch.setattr(tempfile, "_candidate_tempdir_list", lambda: [env["TMPDIR"]])
        monkeypatch.setattr(tempfile, "gettempdir", lambda: env["TMPDIR"])
    assert c_path("/dev/ttyS0", None) == str(PortHandover("/dev/ttyS0").path)


def test_c_reads_what_python_wrote_and_python_what_c_wrote(tmp_path: Path) -> None:
    port = "/dev/ttyUSB7"
    py = PortHandover(port, tmp_path)
    now = c_now()  # both libraries use CLOCK_MONOTONIC (time.monotonic_ns)
    assert c_call("shim_handover_until", port, tmp_path, now) == -(2**63)  # no record: nobody had the port
    py.cover(now + 300 * MS, now)  # a Python process sending
    until = c_call("shim_handover_until", port, tmp_path, c_now())
    assert abs(until - (now + 300 * MS + AHEAD_NS)) < 50 * MS
    py.settle(None, now)  # its draining close
    assert c_call("shim_handover_until", port, tmp_path, now) == -(2**63)

    now = c_now()
    assert c_call("shim_handover_cover", port, tmp_path, now + 200 * MS, now) == 0  # a C process sending
    got = PortHandover(port, tmp_path).predecessor_until(c_now())
    assert got is not None and abs(got - (now + 200 * MS + AHEAD_NS)) < 50 * MS
    assert c_call("shim_handover_settle", port, tmp_path, now + 100 * MS, now) == 0  # killed: the exact instant
    got = PortHandover(port, tmp_path).predecessor_until(c_now())
    assert got is not None and abs(got - (now + 100 * MS)) < 50 * MS
    assert c_call("shim_handover_settle", port, tmp_path, -(2**63), now) == 0
    assert PortHandover(port, tmp_path).predecessor_until(now) is None
    assert not any(tmp_path.iterdir())  # no temporary file left behind


def test_damaged_records_read_alike(tmp_path: Path) -> None:
    port = "/dev/ttyS3"
    path = PortHandover(port, tmp_path).path
    for text, want in [("garbage\n", 5 + PLACEHOLDER_NS), ("", 5 + PLACEHOLDER_NS),
                       ("9" * 30 + "\n", 5 + MAX_WAIT_NS), ("\xff\xfe", 5 + PLACEHOLDER_NS)]:
        path.write_bytes(text.encode("latin-1"))
        assert PortHandover(port, tmp_path).predecessor_until(5) == want
        assert c_call("shim_handover_until", port, tmp_path, 5) == want, text
    os.unlink(path)
