"""asyncio: futures completed on the loop while the event loop keeps running."""

import asyncio
import os
import select
import time
import tty

import pytest

import tether


def test_call_async_completes_on_the_loop(romi_client):
    async def main():
        ticks = 0

        async def ticker():
            nonlocal ticks
            while True:
                ticks += 1
                await asyncio.sleep(0.001)

        task = asyncio.create_task(ticker())
        answers = await asyncio.gather(*(romi_client.call_async("s", i, 1) for i in range(5)))
        task.cancel()
        return answers, ticks

    answers, ticks = asyncio.run(main())
    assert answers == [[0, i + 1] for i in range(5)]
    assert ticks > 0  # the loop ran while the calls were waiting


def test_call_async_raises_the_codec_error(romi_client):
    async def main():
        return await romi_client.call_async("f")

    with pytest.raises(tether.RomiError) as caught:
        asyncio.run(main())
    assert caught.value.code == 101


def test_call_async_needs_a_running_loop(romi_client):
    with pytest.raises(RuntimeError):
        romi_client.call_async("a")


def test_proxy_set_async():
    async def main(client):
        await client.servo(9).init_async(90)
        return await client.servo(9).set_async(100)

    with tether.VirtualUno("proxy", seed=2) as board:
        with tether.proxy.Client(board) as client:
            assert asyncio.run(main(client)).acked


def _wire_line(fd, timeout):
    """The next line the client wrote to the pty (the device's end), or None after ``timeout`` seconds."""
    data = b""
    deadline = time.monotonic() + timeout
    while not data.endswith(b"\n"):
        left = deadline - time.monotonic()
        if left <= 0 or not select.select([fd], [], [], left)[0]:
            return None
        data += os.read(fd, 256)
    return data


def test_cancelling_the_task_cancels_the_wire_call():
    # The test is the device, on the pty's other end, and never answers. A call waits up to an hour for its
    # answer, so the next call reaches the wire soon only if cancelling the first task cancelled the call.
    transport = tether.transports.pty()
    device = os.open(transport.path, os.O_RDWR | os.O_NOCTTY)
    tty.setraw(device)
    try:
        with tether.romi.Client(transport, attempt_timeout=3600, call_budget=3600) as client:

            async def main():
                loop = asyncio.get_running_loop()
                first = asyncio.ensure_future(client.call_async("e"))
                sent = await loop.run_in_executor(None, _wire_line, device, 30)
                assert sent is not None and sent.startswith(b"#e"), sent
                first.cancel()
                with pytest.raises(asyncio.CancelledError):
                    await first
                second = asyncio.ensure_future(client.call_async("a"))
                # Without the cancellation the client still waits for the first answer: nothing is sent.
                after = await loop.run_in_executor(None, _wire_line, device, 30)
                second.cancel()
                return after

            after = asyncio.run(main())
            assert after is not None, "the cancelled call still held the device: the next call was not sent"
            assert after.startswith(b"#a"), after
    finally:
        os.close(device)
