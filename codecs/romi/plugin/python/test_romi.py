"""tether.romi.Client against the romi-test image on a virtual Uno, through its pty (a serial port)."""

import threading
import time

import pytest

import tether


def test_call_returns_the_answer_as_a_list(romi_client):
    assert romi_client.call("e") == [0, 1, 2]
    assert romi_client.call("s[2,3]") == [0, 5]


def test_built_call_with_ints_and_a_string(romi_client):
    assert romi_client.call("s", 32767, 1) == [0, 32768]
    assert romi_client.call("t", "hello") == [0, "hello"]


def test_application_error_raises_romi_error_with_code_and_message(romi_client):
    with pytest.raises(tether.RomiError) as caught:
        romi_client.call("f")
    assert caught.value.code == 101
    assert caught.value.message == "I will try again tomorrow"
    assert caught.value.response == [101, "I will try again tomorrow"]
    assert romi_client.call("f", check=False) == [101, "I will try again tomorrow"]


def test_unknown_opcode_is_the_devices_minus_16(romi_client):
    with pytest.raises(tether.RomiError) as caught:
        romi_client.call("z")
    assert caught.value.code == -16
    assert not isinstance(caught.value, ValueError)  # the device answered: not a rejected command


def test_log_lines_reach_the_callback(romi_client):
    lines = []
    done = threading.Event()

    def on_log(text):
        lines.append(text)
        if len(lines) == 3:
            done.set()

    romi_client.on_log(on_log)
    assert romi_client.call("g", 3) == [0]
    assert done.wait(5)
    assert lines == ["log 1", "log 2", "log 3"]


def test_log_lines_as_an_iterator(romi_client):
    lines = romi_client.log_lines(timeout=5.0)
    assert iter(lines) is lines
    assert romi_client.call("g", 3) == [0]
    taken = []
    for line in lines:  # the lines arrived before the answer: no wait
        taken.append(line)
        if len(taken) == 3:
            break
    assert taken == ["log 1", "log 2", "log 3"]
    assert lines.dropped == 0


def test_log_line_iterator_and_callback_both_get_every_line(romi_client):
    seen = []
    romi_client.on_log(seen.append)
    first = romi_client.log_lines(timeout=5.0)
    second = romi_client.log_lines(timeout=5.0)
    assert romi_client.call("g", 2) == [0]
    assert [next(first), next(first)] == ["log 1", "log 2"]
    assert [next(second), next(second)] == ["log 1", "log 2"]
    assert seen == ["log 1", "log 2"]


def test_log_line_iteration_ends_on_timeout_and_on_close(romi_client):
    # Only lines from the iterator's creation on; none come: the timeout ends the iteration.
    assert list(romi_client.log_lines(timeout=0.2)) == []
    lines = romi_client.log_lines()  # no timeout: waits while the client is open
    assert romi_client.call("g", 1) == [0]
    assert next(lines) == "log 1"
    closer = threading.Timer(0.2, romi_client.close)
    closer.start()
    assert list(lines) == []  # ends when the client closes, not after a timeout
    closer.join()
    stopped = romi_client  # closed: asking for lines now is ClosedError
    with pytest.raises(tether.ClosedError):
        stopped.log_lines()


def test_log_line_iterator_close_and_bad_timeout(romi_client):
    lines = romi_client.log_lines(timeout=1.0)
    lines.close()
    assert romi_client.call("g", 1) == [0]
    assert list(lines) == []
    with pytest.raises(ValueError):
        romi_client.log_lines(timeout=-1)
    with pytest.raises(TypeError):
        romi_client.log_lines(timeout="soon")


def test_counters(romi_client):
    romi_client.call("a")
    romi_client.call("a")
    counters = romi_client.counters()
    assert counters.link.frames_ok >= 2
    assert counters.link.crc_errors == 0


def advance_until(board, done, limit, step=0.0005):
    """Advances a held board in steps until ``done()``, at most ``limit`` seconds of its time; returns its time."""
    start = board.simulated_time
    while not done():
        assert board.simulated_time - start < limit, "the board ran for its limit without it happening"
        board.run_for(step)
        time.sleep(0.001)  # let the io thread write what it has to write
    return board.simulated_time


def test_silent_device_times_out_exactly_at_its_window_in_board_time(held_board, call_in_thread):
    # The board moves only when the test advances it: the 0.3 s attempt window is the board's 0.3 s.
    with tether.romi.Client(held_board, attempt_timeout=0.3, call_budget=0.5) as client:
        received = held_board.stats().rx_bytes
        call = call_in_thread(client.call, "w", 1500)  # busy-waits 1.5 s of simulated time: never answers in time
        # The request went out at most one step before its first byte reached the board.
        arrived = advance_until(held_board, lambda: held_board.stats().rx_bytes > received, limit=1.0)
        held_board.run_for(0.29)
        call.join(0.5)  # half a second of wall time: a steady-clock window would have ended
        assert call.is_alive(), call.error
        held_board.run_for(0.02)  # past the window: the board stands still at arrival + 0.31 s
        call.join(60)
        assert isinstance(call.error, TimeoutError) and isinstance(call.error, tether.RomiTimeoutError), call.error
        assert call.error.code == -25
        assert held_board.simulated_time - arrived == pytest.approx(0.31, abs=1e-6)
        assert client.counters().link.timeouts == 1


def test_a_board_slower_than_real_time_does_not_time_its_calls_out(held_board, call_in_thread):
    # Regression: clients on a virtual board ran on the wall clock, so a board slowed by a loaded machine
    # could have a call time out before the device had run for its window. Here the board stands still for
    # five windows of wall time while the call waits, then runs: the call gets its answer.
    with tether.romi.Client(held_board, attempt_timeout=0.2, call_budget=0.4) as client:
        written = held_board.stats().tx_bytes
        call = call_in_thread(client.call, "s", 20, 22)
        call.join(1.0)
        assert call.is_alive(), call.error
        # Run the board until the firmware has written its answer and the line has carried it (~2 ms of
        # board time), then hold it, far inside the window: only the answer can end the call now, however
        # late the io thread gets to it.
        advance_until(held_board, lambda: held_board.stats().tx_bytes > written, limit=0.1)
        held_board.run_for(0.005)
        call.join(60)
        assert call.error is None
        assert call.result == [0, 42]
        assert client.counters().link.timeouts == 0


def test_board_time_is_the_clients_clock_on_a_running_board(romi_board):
    # Opened on the port with clock=board.clock, or on the board (which implies it): a window never ends
    # before the board has run for it, whatever the machine's load.
    with tether.romi.Client(romi_board.port, boot_wait=0, attempt_timeout=0.3, clock=romi_board.clock) as client:
        sent = romi_board.simulated_time
        with pytest.raises(tether.RomiTimeoutError):
            client.call("w", 1500)
        assert romi_board.simulated_time - sent >= 0.299  # the clock counts whole milliseconds


def test_a_client_keeps_the_board_it_was_opened_on():
    client = tether.romi.Client(tether.VirtualUno("romi-test", seed=1))  # no other reference to the board
    try:
        assert client.call("e") == [0, 1, 2]
    finally:
        client.close()


def test_closing_the_board_closes_the_clients_on_its_clock(held_board, call_in_thread):
    # A closed board's time stands still: its clients' waits would never end, so they are closed with it.
    client = tether.romi.Client(held_board)
    call = call_in_thread(client.call, "e")
    call.join(0.2)
    held_board.close()
    call.join(60)
    assert isinstance(call.error, tether.ClosedError), call.error
    assert not client.is_open
    with pytest.raises(tether.ClosedError):
        tether.romi.Client(held_board)


def test_calls_from_several_threads_are_serialised(romi_client):
    results = []

    def worker(n):
        for i in range(5):
            results.append((romi_client.call("s", n, i), n + i))

    threads = [threading.Thread(target=worker, args=(n,)) for n in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert len(results) == 20
    assert all(answer == [0, total] for answer, total in results)


def test_transport_objects_are_accepted(romi_board):
    transport = tether.transports.serial(romi_board.port, boot_wait=0)
    assert transport.path == romi_board.port
    with tether.romi.Client(transport, clock=romi_board.clock) as client:
        assert client.call("a") == [0]
    assert transport.taken
