"""CompileLog against the call graph of freshly defined kernels (numba must compile them), and
the command line's status display of a compile, on a terminal and off one."""

import io

import numba
import pytest
from rich.console import Console

from thesis_rbd._numba.compile_log import CompileLog
from thesis_rbd._run_status import COMPILING_MESSAGE, COMPILING_NOTE, RunStatus


def fresh_kernels():
    """A caller and its callee, new function objects each time: no cache can hold them."""

    @numba.njit
    def callee(x):
        return x * 2.0 + 1.0

    @numba.njit
    def caller(x):
        return callee(x) - 3.0

    return caller, callee


def test_nested_compiles_are_recorded_with_their_own_and_total_time():
    caller, _ = fresh_kernels()
    started, ended = [], []
    with CompileLog(on_start=started.append, on_end=ended.append) as log:
        assert caller(2.0) == 2.0
    assert [record.name.rsplit(".", 1)[-1] for record in log.records] == ["callee", "caller"]
    callee_record, caller_record = log.records
    assert (callee_record.depth, caller_record.depth) == (1, 0)
    assert callee_record.signature == caller_record.signature == "(float64)"
    # the caller's time includes its callee's; its own time is the difference
    assert caller_record.seconds >= callee_record.seconds > 0
    assert caller_record.own_seconds == pytest.approx(
        caller_record.seconds - callee_record.seconds, abs=1e-9
    )
    assert callee_record.own_seconds == callee_record.seconds
    assert 0 < caller_record.own_cpu_seconds <= caller_record.cpu_seconds
    # outermost compiles only: the wall time spent compiling is the caller's
    assert log.seconds == caller_record.seconds and log.kernel_count == 2
    assert started == [caller_record.name] and ended == [caller_record]
    assert log.slowest(1)[0].own_seconds == max(r.own_seconds for r in log.records)
    assert not log.compiling


def test_nothing_is_recorded_once_compiled_or_outside_the_block():
    caller, _ = fresh_kernels()
    caller(1.0)  # compiled here, outside any log
    with CompileLog() as log:
        caller(5.0)  # same signature: no compile
    assert log.records == []
    caller_int, _ = fresh_kernels()
    with CompileLog() as log:
        pass
    caller_int(1)  # after the block: not recorded
    assert log.records == []


def test_a_new_signature_is_a_new_compile():
    caller, _ = fresh_kernels()
    caller(1.0)
    with CompileLog() as log:
        caller(1)  # int64: compiled again, with its callee
    assert {record.signature for record in log.records} == {"(int64)"}
    assert len(log.records) == 2


def test_status_shows_a_spinner_on_a_terminal_while_compiling():
    screen = io.StringIO()
    console = Console(file=screen, force_terminal=True, width=100)
    status = RunStatus("demo", console=console)
    caller, _ = fresh_kernels()

    def started(kernel):
        status.compiling(kernel)
        # draw now: a small kernel can compile before the live display's first refresh
        status.display.refresh()

    with CompileLog(on_start=started, on_end=lambda _: status.compiling(None)):
        caller(1.0)
    status.close()
    assert COMPILING_MESSAGE in screen.getvalue() and "caller" in screen.getvalue()


def test_status_says_it_once_on_one_line_elsewhere_and_nothing_when_quiet():
    screen = io.StringIO()
    status = RunStatus("demo", console=Console(file=screen, force_terminal=False))
    for _ in range(3):
        status.compiling("thesis_rbd.some.kernel")
        status.compiling(None)
    status(5, 10)  # no progress bar off a terminal
    status.close()
    assert screen.getvalue() == COMPILING_NOTE + "\n"
    silent = io.StringIO()
    quiet = RunStatus("demo", enabled=False, console=Console(file=silent, force_terminal=True))
    quiet.compiling("thesis_rbd.some.kernel")
    quiet(5, 10)
    quiet.close()
    assert silent.getvalue() == ""


def test_warmup_ranks_kernels_by_own_time_summed_over_signatures():
    from thesis_rbd._numba.compile_log import KernelCompile
    from thesis_rbd._numba.warmup import slowest_kernels

    def record(name, own):
        return KernelCompile(name, "(float64)", own + 1.0, own, own, own, 0)

    ranked = slowest_kernels([record("a", 2.0), record("b", 3.0), record("a", 1.5)])
    assert ranked == [("a", 2, 3.5), ("b", 1, 3.0)]
