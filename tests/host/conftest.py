"""The host tests on either protocol core.

The managers run the core urb.managers.native chooses (the C core when built; URB_HOST_CORE=python
the reference). The tests that build a core themselves (`Rs232Core(...)`, `UsbCore(...)`) test the
reference, unless URB_TEST_CORES=c: then those names, in each test module, are the C core's
NativeRs232Core and NativeUsbCore, so that the whole host suite runs on the C core
(host/urb/README.md, "The protocol core in C", lists what that measures).
"""

from __future__ import annotations

import os

import pytest

from urb.managers import native


@pytest.fixture(autouse=True)
def cores_under_test(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> None:
    setting = os.environ.get("URB_TEST_CORES", "")
    if setting not in ("", "c"):
        pytest.fail(f"URB_TEST_CORES={setting!r}: use c (the tests' own cores on the C core) or leave it unset")
    if setting != "c":
        return
    if native.BACKEND != "c":
        pytest.fail(f"URB_TEST_CORES=c, but the C core is not in use: {native.REASON}")
    module = request.module
    for name, cls in (("Rs232Core", native.NativeRs232Core), ("UsbCore", native.NativeUsbCore)):
        if hasattr(module, name):
            monkeypatch.setattr(module, name, cls)
