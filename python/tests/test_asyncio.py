"""asyncio: futures completed on the loop while the event loop keeps running."""

import asyncio

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
        with tether.proxy.Client(board.port, boot_wait=0) as client:
            assert asyncio.run(main(client)).acked
