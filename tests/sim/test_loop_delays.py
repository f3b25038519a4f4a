"""The sensor-to-actuator delay of Figs. 18-19 (urb_sim.experiments.control.loop_delays) on mark logs
written by hand: node updates every 1 ms (ACQ_END at k ms), the bridge reads the feedback 0.4 ms
later, the node drives the command computed from it at the update two periods after the sample.

The old measurement matched a command to the first drive with its value up to 20 ms after the
read: a command overwritten in the node's inbox before an update took it (the inbox keeps the
newest) was matched to a later command that happened to have the same value, a spurious 21-ms
delay in the report (RS232, seeds 2 and 4). Now only updates that took a new command count, in
order."""

from __future__ import annotations

from urb_sim.experiments.control import DRIVE_FRESH, loop_delays
from urb_sim.native import Mark

MS = 1_000_000


def drive(t: int, mv: int, fresh: bool = True) -> tuple[int, int, int]:
    return (t, int(Mark.DRIVE), (mv + 0x8000) | (DRIVE_FRESH if fresh else 0))


def log(commands: list[int], applied: dict[int, int]) -> list[tuple[int, int, int]]:
    """Updates at 1..N+3 ms; command k (read at k ms + 0.4) is applied at the update given by
    `applied[k]` (ms), or never; an update without a new command drives the previous one again."""
    marks: list[tuple[int, int, int]] = []
    at_update = {ms: k for k, ms in applied.items()}
    current = 0
    for ms in range(1, len(commands) + 4):
        marks.append((ms * MS, int(Mark.ACQ_END), 0))
        if ms in at_update:
            current = commands[at_update[ms]]
            marks.append(drive(ms * MS + 50_000, current))
        else:
            marks.append(drive(ms * MS + 50_000, current, fresh=False))
        marks.append((ms * MS + 400_000, int(Mark.READ), 0))
    return sorted(marks)


def test_every_applied_command_is_two_periods() -> None:
    cmds = [100, 200, 300, 400, 500]
    got = loop_delays(log(cmds, {k: k + 3 for k in range(5)}), cmds)
    assert got.superseded == 0
    assert got.delays == [2.05] * 5


def test_an_overwritten_command_is_superseded_not_matched_to_a_later_equal_one() -> None:
    """Command 2 (value 300) is overwritten by command 3 before an update took it; command 10 has
    the same value 300. The old matcher gave command 2 the drive of command 10 (10 ms late)."""
    cmds = [100, 200, 300, 400, 500, 600, 700, 800, 900, 1000, 300, 1100]
    applied = {k: k + 3 for k in range(12) if k != 2}
    got = loop_delays(log(cmds, applied), cmds)
    assert got.superseded == 1
    assert max(got.delays) < 2.1 and len(got.delays) == 11


def test_equal_neighbours_have_no_delay() -> None:
    """Which of two equal consecutive commands an update applied cannot be told apart: neither counts."""
    cmds = [100, 250, 250, 400]
    got = loop_delays(log(cmds, {0: 3, 1: 4, 2: 5, 3: 6}), cmds)
    assert got.delays == [2.05, 2.05]
    assert got.superseded == 0


def test_a_late_update_shows_as_a_longer_delay() -> None:
    """From command 1 on the commands reach the node just after the update they were due at (the
    host loop's phase): each is applied a period later."""
    cmds = [100, 200, 300]
    got = loop_delays(log(cmds, {0: 3, 1: 5, 2: 6}), cmds)
    assert got.delays == [2.05, 3.05, 3.05]
    assert got.superseded == 0
