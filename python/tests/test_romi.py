"""tether.romi.Client against the romi-test image on a virtual Uno, through its pty (a serial port)."""

import threading

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


def test_silent_device_times_out_as_timeout_error(romi_board):
    with tether.romi.Client(romi_board.port, boot_wait=0, attempt_timeout=0.3, call_budget=0.5) as client:
        with pytest.raises(TimeoutError) as caught:
            client.call("w", 1500)  # busy-waits 1.5 s of simulated time: never within 0.5 s
        assert isinstance(caught.value, tether.RomiTimeoutError)
        assert caught.value.code == -25


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
    with tether.romi.Client(transport) as client:
        assert client.call("a") == [0]
    assert transport.taken
