"""The critical-section measurement (urb_sim.critical; issue #40) on disassembly written here, so
that each rule is seen to hold and to fail: the worst path through a call and a bounded loop, a
changed section that makes the committed table stale, a loop without a bound, a return with
interrupts masked. `make sim-critical-check` compares the committed table with the real images."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from urb_sim import critical

SLEEP = """
08000100 <sleep>:
 8000100:	b510      	push	{r4, lr}
 8000102:	b672      	cpsid	i
 8000104:	f000 f806 	bl	8000114 <has_work>
 8000108:	2800      	cmp	r0, #0
 800010a:	d100      	bne.n	800010e <sleep+0xe>
 800010c:	bf30      	wfi
 800010e:	b662      	cpsie	i
 8000110:	bd10      	pop	{r4, pc}

08000114 <has_work>:
 8000114:	2200      	movs	r2, #0
 8000116:	5c83      	ldrb	r3, [r0, r2]
 8000118:	3201      	adds	r2, #1
 800011a:	2a04      	cmp	r2, #4
 800011c:	d1fb      	bne.n	8000116 <has_work+0x2>
 800011e:	4770      	bx	lr
"""


def _table(text: str) -> list[dict[str, Any]]:
    funcs = critical.parse(text)
    return critical.sections(funcs, "node", "x.c")


def test_the_worst_path_runs_the_call_and_its_loop_to_its_bound(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(critical.LOOP_BOUNDS, "has_work", (4, "x.c", "bound: 4"))
    [section] = _table(SLEEP)
    # has_work: movs 1, 4 x (ldrb 2 + adds 1 + cmp 1), bne taken 3 x 2 + not taken 1, bx 2 = 26
    # sleep after cpsid: bl 3 + 26 + cmp 1 + bne not taken 1 + wfi 2 + cpsie 1 = 34
    assert section["id"] == "node:sleep" and section["cycles"] == 34
    assert section["instructions"] == 1 + 18 + 4  # bl; has_work: movs, 4 x 4 in the loop, bx; cmp, bne, wfi, cpsie
    assert int(section["fetches"]) > 0


def test_one_more_instruction_in_the_section_changes_the_table(monkeypatch: pytest.MonkeyPatch) -> None:
    """What makes `critical --check` fail when the code changes: a seeded extra store."""
    monkeypatch.setitem(critical.LOOP_BOUNDS, "has_work", (4, "x.c", "bound: 4"))
    changed = SLEEP.replace(" 8000108:\t2800      \tcmp\tr0, #0\n",
                            " 8000108:\t2800      \tcmp\tr0, #0\n 8000109:\t6003      \tstr\tr3, [r0, #0]\n")
    assert int(_table(changed)[0]["cycles"]) == int(_table(SLEEP)[0]["cycles"]) + 2


def test_a_loop_without_a_stated_bound_is_refused() -> None:
    with pytest.raises(critical.CriticalError, match="has_work has a loop .* without a bound"):
        _table(SLEEP)


def test_a_backward_jump_to_shared_code_is_not_a_loop() -> None:
    text = """
00000100 <idle>:
     100:	b672      	cpsid	i
     102:	2800      	cmp	r0, #0
     104:	d002      	beq.n	10c <idle+0xc>
     106:	2001      	movs	r0, #1
     108:	b662      	cpsie	i
     10a:	4770      	bx	lr
     10c:	2000      	movs	r0, #0
     10e:	e7fb      	b.n	108 <idle+0x8>
"""
    [section] = _table(text)
    assert section["cycles"] == 1 + 2 + 1 + 2 + 1  # cmp, beq taken, movs, b, cpsie


def test_returning_with_interrupts_masked_is_refused() -> None:
    text = """
00000100 <leaky>:
     100:	b672      	cpsid	i
     102:	4770      	bx	lr
"""
    with pytest.raises(critical.CriticalError, match="returns at 0x102 with interrupts still masked"):
        _table(text)


def test_an_instruction_without_a_timing_is_refused() -> None:
    text = """
00000100 <odd>:
     100:	b672      	cpsid	i
     102:	bf40      	sev
     104:	b662      	cpsie	i
"""
    with pytest.raises(critical.CriticalError, match="no Cortex-M0\\+ cycle count for 'sev'"):
        _table(text)


def test_the_committed_table_names_each_device_s_worst_section() -> None:
    table = critical.load()
    assert table["worst"] == {"node": "node:urb_hal_cm0_sleep", "bridge": "bridge:main"}
    assert all(s["cycles"] > 0 and s["fetches"] > 0 for s in table["sections"])


def test_check_fails_when_the_committed_table_is_stale(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    """`make sim-critical-check`: the committed table against the measured one."""
    table = tmp_path / "critical_sections.json"
    section: dict[str, Any] = {"id": "node:sleep", "cycles": 34, "fetches": 12}
    measured: dict[str, Any] = {"about": "", "sections": [section], "worst": {}}
    monkeypatch.setattr(critical, "TABLE", table)
    monkeypatch.setattr(critical, "REPO", tmp_path)
    monkeypatch.setattr(critical, "measure", lambda: measured)
    assert critical.main(["--write"]) == 0
    assert critical.main(["--check"]) == 0
    section["cycles"] = 36  # the code changed: the committed table is stale
    assert critical.main(["--check"]) == 1
    assert "critical_sections.json is stale" in capsys.readouterr().err
