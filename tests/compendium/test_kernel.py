"""A kernel's sockets are waited on in short slices (mutual.compendium.kernel.poll_in_slices): against a channel
that misses its wake-up, a reply costs one slice, not the whole timeout, and the timeout still holds."""

import asyncio
import queue
import time

import pytest

from mutual.compendium.kernel import poll_in_slices


class MissedWakeUpChannel:
    def __init__(self, arrives_after):
        self.arrival = time.monotonic() + arrives_after
        self.waits = []

    async def get_msg(self, timeout=None):
        self.waits.append(timeout)
        if time.monotonic() >= self.arrival:
            return {"msg_type": "execute_reply"}
        await asyncio.sleep(3600 if timeout is None else timeout)   # misses the arrival
        raise queue.Empty


def timed(coroutine):
    started = time.monotonic()
    result = asyncio.run(coroutine)
    return result, time.monotonic() - started


def test_a_missed_wake_up_costs_one_slice_not_the_whole_timeout():
    channel = poll_in_slices(MissedWakeUpChannel(arrives_after=0.3), slice_s=0.1)
    reply, seconds = timed(channel.get_msg(timeout=60))
    assert reply == {"msg_type": "execute_reply"}
    assert seconds < 2, seconds
    assert all(w <= 0.1 for w in channel.waits) and len(channel.waits) >= 3


def test_waiting_without_a_timeout_also_polls_afresh():
    channel = poll_in_slices(MissedWakeUpChannel(arrives_after=0.25), slice_s=0.1)
    reply, seconds = timed(channel.get_msg())
    assert reply["msg_type"] == "execute_reply" and seconds < 2


def test_the_timeout_still_holds():
    channel = poll_in_slices(MissedWakeUpChannel(arrives_after=1e9), slice_s=0.1)
    started = time.monotonic()
    with pytest.raises(queue.Empty):
        asyncio.run(channel.get_msg(timeout=0.35))
    assert 0.3 <= time.monotonic() - started < 1.5
    assert max(channel.waits) <= 0.1 + 1e-9
