"""One Jupyter kernel executing one notebook (for :mod:`.notebooks`): start it, run its cells, route SIGINT and
SIGTERM to it (interrupt the cell, then kill the kernel after a grace period), shut it down and say how it died.
Its sockets are waited on in short slices (:func:`poll_in_slices`), so a missed wake-up cannot hang a run."""

import asyncio
import queue
import signal
import threading
import time

KERNEL = "mutual"
INTERRUPT_GRACE = 10     # seconds an interrupted kernel gets to unwind its cell before it is killed
POLL_SLICE = 1.0         # seconds: the longest single wait on a kernel socket (see poll_in_slices)
KERNEL_START = ["--IPKernelApp.exec_lines=import mutual.compendium.runs as _runs; _runs.quiet_progress_bars(); del _runs"]


def poll_in_slices(channel, slice_s=POLL_SLICE):
    """Make ``channel.get_msg(timeout)`` wait in slices of at most ``slice_s`` seconds.

    nbclient's mimic of the Output widget (``interact`` views) sends on the shell socket while the
    cell's reply is awaited on that same zmq.asyncio socket; now and then that wait misses its wake-up
    and a single poll then sleeps until the cell times out (30 min), with the kernel long idle
    (jupyter/nbclient#312). Each new poll looks at the socket afresh, so a missed wake-up costs at most
    one slice."""
    get_msg = channel.get_msg

    async def sliced(timeout=None):
        deadline = None if timeout is None else time.monotonic() + timeout
        while True:
            left = slice_s if deadline is None else min(slice_s, max(0.0, deadline - time.monotonic()))
            try:
                return await get_msg(timeout=left)
            except queue.Empty:
                if deadline is not None and time.monotonic() >= deadline:
                    raise

    channel.get_msg = sliced
    return channel


class KernelRun:
    """One kernel executing one notebook, and what happened to it."""

    def __init__(self, nb, path, timeout, env, loop, log):
        self.nb, self.path, self.timeout, self.env, self.loop, self.log = nb, path, timeout, env, loop, log
        self.km = self.client = self.task = self.watchdog = None
        self.cell = self.signum = self.exit_status = None
        self.killed = False

    async def cells(self):
        from jupyter_client.manager import AsyncKernelManager
        from nbclient import NotebookClient
        from nbclient.util import ensure_async

        self.km = AsyncKernelManager(kernel_name=KERNEL)
        self.client = NotebookClient(self.nb, km=self.km, kernel_name=KERNEL, timeout=self.timeout,
                                     extra_arguments=list(KERNEL_START),
                                     resources={"metadata": {"path": str(self.path.parent)}})
        await self.client.async_start_new_kernel(env=self.env, stdout=self.log, stderr=self.log)
        await self.client.async_start_new_kernel_client()
        for channel in (self.client.kc.shell_channel, self.client.kc.iopub_channel):
            poll_in_slices(channel)
        info = await self.client.async_wait_for_reply(await ensure_async(self.client.kc.kernel_info()))
        if info is not None and "language_info" in info["content"]:
            self.nb.metadata["language_info"] = info["content"]["language_info"]
        for index, cell in enumerate(self.nb.cells):
            if self.signum is not None:
                raise asyncio.CancelledError
            self.cell = index
            await self.client.async_execute_cell(cell, index, execution_count=self.client.code_cells_executed + 1)
        self.cell = None
        self.client.set_widgets_metadata()

    def on_signal(self, signum):
        """First signal: interrupt the running cell, and kill the kernel if it has not stopped within
        ``INTERRUPT_GRACE`` seconds. A second signal kills it at once."""
        first = self.signum is None
        self.signum = self.signum or signum
        if first and self.km is not None and self.km.has_kernel:
            self.watchdog = self.loop.create_task(self._interrupt())
        else:
            self.stop_now()

    def stop_now(self):
        self.killed = True
        if self.task is not None:
            self.task.cancel()

    async def _interrupt(self):
        try:
            await self.km.interrupt_kernel()
        except Exception:  # noqa: BLE001 (the kernel may already be gone; stop_now follows)
            pass
        await asyncio.sleep(INTERRUPT_GRACE)
        self.stop_now()

    async def shutdown(self):
        if self.watchdog is not None:
            self.watchdog.cancel()
        if self.km is None:
            return
        try:
            self.exit_status = await self.km.provisioner.poll() if self.km.provisioner else None
        except Exception:  # noqa: BLE001
            self.exit_status = None
        if self.client is not None and self.client.kc is not None:
            self.client.kc.stop_channels()
        try:
            if self.km.has_kernel:
                await self.km.shutdown_kernel(now=self.killed or self.exit_status is not None)
        except Exception:  # noqa: BLE001 (a dead kernel's resources are released either way)
            pass

    def death(self):
        """How the kernel process ended: ``killed by SIGKILL``, ``exit status 1`` or ``no exit status``."""
        status = self.exit_status
        if isinstance(status, int) and status < 0:
            return f"killed by {signal.Signals(-status).name}"
        return f"exit status {status}" if status is not None else "no exit status"


def route_signals(run):
    """Route SIGINT and SIGTERM to ``run`` while it executes; returns a function that restores
    the previous handlers (only the main thread can set them)."""
    if threading.current_thread() is not threading.main_thread():
        return lambda: None
    signals = (signal.SIGINT, signal.SIGTERM)
    old = {s: signal.getsignal(s) for s in signals}
    for s in signals:
        signal.signal(s, lambda signum, frame: run.loop.call_soon_threadsafe(run.on_signal, signum))
    return lambda: [signal.signal(s, h) for s, h in old.items()]
