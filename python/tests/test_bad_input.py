"""Bad input gets a Python exception, never a crash or a hang: wrong types, out-of-range values, closed
clients, ports that do not exist, a device that answers garbage."""

import json
import os
import signal
import socket
import threading
import time

import pytest

import tether


def test_wrong_argument_types(romi_client):
    with pytest.raises(TypeError):
        romi_client.call("s", 1.5, 2)
    with pytest.raises(TypeError):
        romi_client.call("s", None, 2)
    with pytest.raises(TypeError):
        romi_client.call(42)
    with pytest.raises(TypeError):
        tether.romi.Client(42)
    with pytest.raises(TypeError):
        romi_client.on_log(5)


def test_out_of_range_romi_values_are_rejected_before_sending(romi_client):
    with pytest.raises(tether.RomiCommandError) as caught:
        romi_client.call("s", 40000, 1)
    assert caught.value.code == -10 and isinstance(caught.value, ValueError)
    # One mistake, one exception, whatever the size (2**40 was a plain ValueError, 2**63 a RuntimeError).
    for value in (40000, -40000, 2**31, 2**40, 2**63, -2**63 - 1, 2**200):
        with pytest.raises(tether.RomiCommandError) as caught:
            romi_client.call("s", value, 1)
        assert caught.value.code == -10, value
    with pytest.raises(tether.RomiCommandError) as caught:
        romi_client.call("")
    assert caught.value.code == -24
    with pytest.raises(tether.RomiCommandError):
        romi_client.call("#a")
    with pytest.raises(ValueError):
        romi_client.call("ab", 1)
    with pytest.raises(ValueError):
        romi_client.call("t", "x", 1)  # the string comes last
    assert romi_client.call("a") == [0]  # the client still works


def test_bad_options_are_value_errors(romi_board):
    with pytest.raises(ValueError):
        tether.romi.Client(romi_board.port, boot_wait=0, attempt_timeout=0)
    with pytest.raises(ValueError):
        tether.romi.Client(romi_board.port, boot_wait=0, max_attempts=0)
    with pytest.raises(ValueError):
        tether.romi.Client(romi_board.port, boot_wait=-1)
    with pytest.raises(tether.TransportError):
        tether.transports.serial(romi_board.port, baud=12345, boot_wait=0)
    with pytest.raises(ValueError):
        tether.transports.tcp("localhost", 70000)


def test_closed_client_raises_closed_error(romi_board):
    client = tether.romi.Client(romi_board)
    client.close()
    client.close()  # idempotent
    assert not client.is_open
    with pytest.raises(tether.ClosedError):
        client.call("a")
    with pytest.raises(tether.ClosedError):
        client.counters()


def test_close_from_another_thread_ends_a_waiting_call(held_board, call_in_thread):
    # The board stands still: the call cannot time out, only the close can end it.
    client = tether.romi.Client(held_board)
    call = call_in_thread(client.call, "e")
    call.join(0.2)
    client.close()
    call.join(60)
    assert isinstance(call.error, tether.ClosedError), call.error


def _interrupter(client):
    """A thread that sends SIGINT to this process, then closes ``client`` 20 s later should the call it
    interrupts still be waiting (so a call that ignores Ctrl-C fails the test instead of hanging it)."""
    def interrupt():
        os.kill(os.getpid(), signal.SIGINT)
        if not done.wait(20):
            client.close()

    done = threading.Event()
    thread = threading.Thread(target=interrupt, daemon=True)
    return thread, done


@pytest.mark.parametrize("kind", ["romi", "proxy", "elcano"])
def test_ctrl_c_ends_a_blocking_call_at_once(kind):
    # The board stands still: the call can end only by the interrupt (or the safety close).
    image = {"romi": "romi-test", "proxy": "proxy", "elcano": "elcano-node"}[kind]
    with tether.VirtualUno(image, seed=1, start=False) as board:
        if kind == "romi":
            client = tether.romi.Client(board)
            blocking = lambda: client.call("e")
        elif kind == "proxy":
            client = tether.proxy.Client(board)
            blocking = lambda: client.servo(9).set(90)
        else:
            client = tether.elcano.RingClient(board)
            blocking = lambda: client.request(
                tether.elcano.Message(type="goal", number=1, east=1, north=2, bearing=4), reply_type="segment")
        with client:
            thread, done = _interrupter(client)
            timer = threading.Timer(0.3, thread.start)
            timer.start()
            try:
                with pytest.raises(KeyboardInterrupt):
                    blocking()
            finally:
                done.set()
                timer.join()
                if thread.is_alive():
                    thread.join()
            assert client.is_open  # the interrupted call was cancelled; the client goes on


@pytest.mark.parametrize("kind", ["boot_wait", "open_rover"])
def test_ctrl_c_ends_an_opening_at_once(kind, tmp_path):
    # A port whose boot wait is long, a proxy device that never answers its handshake: only the interrupt
    # ends the opening early (it would succeed after 30 s, or fail after 30 s, and the test then fails).
    master, slave = os.openpty()
    port = os.ttyname(slave)
    if kind == "boot_wait":
        opening = lambda: tether.romi.Client(port, boot_wait=30)
    else:
        config = tmp_path / "rover.json"
        config.write_text(json.dumps({"devices": [{
            "name": "silent", "codec": "proxy",
            "transport": {"serial": {"path": port, "boot_wait_ms": 0}},
            "options": {"open_timeout_ms": 30000}}]}))
        opening = lambda: tether.open_rover(config)
    timer = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))
    started = time.monotonic()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            opening()
        assert time.monotonic() - started < 10
    finally:
        timer.join()
        os.close(slave)
        os.close(master)


def test_bad_clocks_and_boards(romi_board, held_board):
    with pytest.raises(TypeError):
        tether.romi.Client(romi_board, clock=1.0)
    with pytest.raises(TypeError):
        tether.proxy.Client(romi_board, clock="board")
    with pytest.raises(TypeError):
        tether.elcano.RingClient(romi_board, clock=object())
    with pytest.raises(ValueError):
        held_board.port  # no pty: clients open on the board itself
    with pytest.raises(ValueError):
        romi_board.run_for(0.1)  # it runs on its own thread
    with pytest.raises(ValueError):
        held_board.run_for(-1)
    with pytest.raises(TypeError):
        held_board.run_for("soon")
    with tether.romi.Client(held_board):
        with pytest.raises(ValueError):
            tether.romi.Client(held_board)  # its UART serves one client at a time
    with tether.romi.Client(held_board):
        pass  # the first one closed: free again
    clock = romi_board.clock
    romi_board.close()
    for closed in (lambda: tether.romi.Client(romi_board), lambda: romi_board.clock,
                   lambda: tether.romi.Client(held_board, clock=clock), lambda: romi_board.simulated_time):
        with pytest.raises(tether.ClosedError):
            closed()


def test_missing_port_and_missing_image():
    with pytest.raises(FileNotFoundError):
        tether.romi.Client("/dev/tether-no-such-port", boot_wait=0)
    with pytest.raises(FileNotFoundError):
        tether.proxy.Client("/dev/tether-no-such-port", boot_wait=0)
    with pytest.raises(FileNotFoundError):
        tether.VirtualUno("no-such-image")
    with pytest.raises(ConnectionRefusedError):
        tether.transports.tcp("127.0.0.1", 1, timeout=2)


def test_nul_in_a_path_and_a_zero_baud_are_value_errors(romi_board, tmp_path):
    # Regression: a NUL cut the image name short (another file was opened); baud=0 was accepted.
    with pytest.raises(ValueError, match="embedded null character"):
        tether.VirtualUno("romi-test\0-other")
    with pytest.raises(ValueError, match="embedded null character"):
        tether.romi.Client(romi_board.port + "\0x", boot_wait=0)
    with pytest.raises(ValueError, match="embedded null character"):
        tether.open_rover(str(tmp_path / "rover.json") + "\0x")
    for make in (lambda: tether.romi.Client(romi_board.port, baud=0, boot_wait=0),
                 lambda: tether.proxy.Client(romi_board.port, baud=0, boot_wait=0),
                 lambda: tether.transports.serial(romi_board.port, baud=0, boot_wait=0),
                 lambda: tether.romi.Client(romi_board, baud=0)):
        with pytest.raises(ValueError, match="baud"):
            make()


def test_a_host_name_that_does_not_resolve_is_a_resolution_error():
    # Regression: it was raised as PermissionError (the resolver's code 1 read as errno EPERM).
    with pytest.raises(socket.gaierror) as caught:
        tether.transports.tcp("tether-no-such-host.invalid", 2000, timeout=5)
    assert not isinstance(caught.value, PermissionError) and str(caught.value)


def test_bad_config_names_the_json_path(tmp_path):
    path = tmp_path / "rover.json"
    path.write_text('{"name": "r", "devices": [{"name": "a", "codec": "mavlink", '
                    '"transport": {"serial": {"path": "/dev/null"}}}]}')
    with pytest.raises(tether.ConfigError) as caught:
        tether.open_rover(path)
    assert "devices[0].codec" in str(caught.value)
    assert caught.value.path == "devices[0].codec"
    with pytest.raises(tether.ConfigError):
        tether.open_rover(tmp_path / "missing.json")


def test_proxy_bad_values():
    with tether.VirtualUno("proxy", seed=2) as board:
        with tether.proxy.Client(board) as client:
            with pytest.raises(ValueError):
                client.servo(-1)
            with pytest.raises(ValueError):
                client.servo(2**32)
            with pytest.raises(TypeError):
                client.servo("9")
            with pytest.raises(ValueError):
                client.servo(9).set(2**31)
            with pytest.raises(TypeError):
                client.servo(9).set(1.5)
            with pytest.raises(ValueError):
                client.digital(13).set(2)
            with pytest.raises(TypeError):
                client.digital(13).set("on")
            handle = client.servo(9)
            client.close()
            with pytest.raises(tether.ClosedError):
                handle.set(90)


def test_elcano_bad_messages():
    with pytest.raises(ValueError):
        tether.elcano.Message(type="fly")
    with pytest.raises(TypeError):
        tether.elcano.Message(type="drive", colour=3)
    with pytest.raises(TypeError):
        tether.elcano.Message(type="drive", speed="fast")
    with pytest.raises(ValueError):
        tether.elcano.Message(type="drive", speed=2**31 - 1)  # the protocol's "unset"
    with pytest.raises(ValueError):
        tether.elcano.Message(type="drive", speed=1).to_wire()  # angle missing
    with pytest.raises(ValueError):
        tether.elcano.Message(type="drive", speed=1, angle=1).to_wire("C")


def test_garbage_answering_device_times_out_and_is_counted():
    pty = tether.transports.pty()
    stop = threading.Event()
    fd = os.open(pty.path, os.O_RDWR | os.O_NOCTTY)

    def babble():
        while not stop.is_set():
            os.write(fd, b"#e[0,1:zz\r\n\x00\xff garbage ]]]#!\r\n#e[0]:9999\r\n")
            stop.wait(0.01)

    thread = threading.Thread(target=babble)
    thread.start()
    try:
        with tether.romi.Client(pty, attempt_timeout=0.2, call_budget=0.4) as client:
            with pytest.raises(tether.RomiError) as caught:
                client.call("e")
            assert caught.value.code in (-25, -1, -2, -3, -4, -5, -6)
            link = client.counters().link
            assert link.crc_errors + link.framing_errors + link.stale > 0
    finally:
        stop.set()
        thread.join()
        os.close(fd)


def test_a_transport_serves_one_client(romi_board):
    transport = tether.transports.serial(romi_board.port, boot_wait=0)
    with tether.romi.Client(transport):
        with pytest.raises(ValueError):
            tether.romi.Client(transport)


def _child_uses_its_own_client(inherited, results):
    """In a forked child: the inherited client refuses, a new board and client work."""
    try:
        inherited.call("e")
        results.put("the inherited client answered")
        return
    except tether.ClosedError as error:
        if "forked" not in str(error):
            results.put(f"unexpected ClosedError: {error}")
            return
    with tether.VirtualUno("romi-test", seed=2) as board:
        with tether.romi.Client(board) as client:
            results.put(client.call("e"))


def test_a_forked_child_opens_its_own_clients(romi_client):
    import multiprocessing
    assert romi_client.call("e") == [0, 1, 2]
    context = multiprocessing.get_context("fork")
    results = context.Queue()
    child = context.Process(target=_child_uses_its_own_client, args=(romi_client, results))
    child.start()
    try:
        answer = results.get(timeout=60)
    finally:
        child.join(60)
        if child.is_alive():
            child.kill()
    assert answer == [0, 1, 2], answer
    assert child.exitcode == 0
    assert romi_client.call("e") == [0, 1, 2]  # the parent's client is untouched
