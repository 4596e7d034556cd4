"""The runner's kernel sockets wait in short slices, so a missed wake-up cannot hang a notebook.

A zmq.asyncio socket that another task sends on can miss the wake-up of a pending poll (nbclient's
Output-widget mimic sends on the shell socket while the cell's reply is awaited on it; seen here as a
notebook whose ``interact`` cell stayed "running" with the kernel idle until the 30-minute cell
timeout). The fake channel below behaves like that: a wait that began before the message arrived
never sees it; a fresh wait does.
"""

import asyncio
import queue
import time

import pytest

from mutual.compendium.notebooks import _poll_in_slices


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
    channel = _poll_in_slices(MissedWakeUpChannel(arrives_after=0.3), slice_s=0.1)
    reply, seconds = timed(channel.get_msg(timeout=60))
    assert reply == {"msg_type": "execute_reply"}
    assert seconds < 2, seconds
    assert all(w <= 0.1 for w in channel.waits) and len(channel.waits) >= 3


def test_waiting_without_a_timeout_also_polls_afresh():
    channel = _poll_in_slices(MissedWakeUpChannel(arrives_after=0.25), slice_s=0.1)
    reply, seconds = timed(channel.get_msg())
    assert reply["msg_type"] == "execute_reply" and seconds < 2


def test_the_timeout_still_holds():
    channel = _poll_in_slices(MissedWakeUpChannel(arrives_after=1e9), slice_s=0.1)
    started = time.monotonic()
    with pytest.raises(queue.Empty):
        asyncio.run(channel.get_msg(timeout=0.35))
    assert 0.3 <= time.monotonic() - started < 1.5
    assert max(channel.waits) <= 0.1 + 1e-9
