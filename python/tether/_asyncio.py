"""Completion of asyncio futures from the library's io thread (scheduled with call_soon_threadsafe)."""


def settle(future, failure, value):
    """Completes ``future`` on its loop, unless it was cancelled meanwhile."""
    if future.done():
        return
    if failure is not None:
        future.set_exception(failure)
    else:
        future.set_result(value)
