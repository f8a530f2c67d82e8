# SPDX-License-Identifier: Apache-2.0
"""Reading a run's inputs beside each other. A log's frames
(:func:`.logfile.read_frames`, numpy only) and the plant's truth CSV do not
need the protocol; reading them in a forked process while the caller loads
the DBC and decodes puts the machine's second core to work. This module
imports nothing heavy, so that the log can be started on before the
protocol is loaded (``stewart analyze`` does so).

The answer comes back through a pipe as a pickle whose numpy arrays travel
out of band (pickle protocol 5): their bytes are written to the pipe as they
are and read into the buffers the arrays are then built on, so a 40 MB log
costs one copy through the kernel instead of pickling, a queue and
unpickling (docs/reference/analysis.md, Cost)."""

from __future__ import annotations

import os
import pickle
import select
import struct
from pathlib import Path
from typing import Any, Callable


class Beside:
    """A job's answer to come: :meth:`result` returns the value or raises
    what the job raised (as ``concurrent.futures.Future.result``)."""

    def __init__(self, pid: int = 0, fd: int = -1, value: Any = None,
                 error: BaseException | None = None):
        self._pid, self._fd = pid, fd
        self._value, self._error = value, error
        self._done = fd < 0

    def result(self, timeout: float | None = None) -> Any:
        """The job's value; raises its exception, TimeoutError when
        ``timeout`` seconds pass without an answer, or OSError when the
        process ended without one."""
        if not self._done:
            self._receive(timeout)
        if self._error is not None:
            raise self._error
        return self._value

    def _receive(self, timeout: float | None) -> None:
        if timeout is not None and not select.select([self._fd], [], [], timeout)[0]:
            raise TimeoutError(f"no answer from the process beside after {timeout} s")
        try:
            with open(self._fd, "rb", buffering=0, closefd=True) as pipe:
                n_head, n_bufs = struct.unpack("<QQ", _read_exact(pipe, 16).tobytes())
                sizes = struct.unpack(f"<{n_bufs}Q", _read_exact(pipe, 8 * n_bufs).tobytes())
                head = _read_exact(pipe, n_head).tobytes()
                buffers = [_read_exact(pipe, size) for size in sizes]
            ok, value = pickle.loads(head, buffers=buffers)
        except EOFError:
            _, status = os.waitpid(self._pid, 0)
            self._done = True
            raise OSError(f"the process reading beside ended without an answer "
                          f"(wait status {status})") from None
        os.waitpid(self._pid, 0)
        self._done = True
        if ok:
            self._value = value
        else:
            self._error = value


def _read_exact(pipe, n: int):
    """``n`` bytes from the pipe (EOFError if it ends first), in a numpy
    buffer: numpy asks the kernel for huge pages for large arrays, and
    mapping 40 MB in 4 KB pages costs more than reading them (40 ms against
    6 ms on the VM of docs/reference/analysis.md)."""
    import numpy as np

    buf = np.empty(n, dtype=np.uint8)
    view = memoryview(buf)
    got = 0
    while got < n:
        k = pipe.readinto(view[got:])
        if not k:
            raise EOFError
        got += k
    return buf


def _write_all(fd: int, data) -> None:
    view = memoryview(data).cast("B")
    while len(view):
        view = view[os.write(fd, view):]


def _answer(fd: int, fn: Callable[..., Any], args: tuple) -> None:
    """In the child: runs the job and writes (ok, value) to ``fd``, the
    arrays' bytes out of band."""
    try:
        answer: tuple[bool, Any] = (True, fn(*args))
    except Exception as exc:  # noqa: BLE001 - handed to the caller by result()
        answer = (False, exc)
    buffers: list[pickle.PickleBuffer] = []
    try:
        head = pickle.dumps(answer, protocol=5, buffer_callback=buffers.append)
    except Exception as exc:  # noqa: BLE001 - an answer that does not pickle
        buffers = []
        head = pickle.dumps((False, RuntimeError(f"the answer does not pickle: {exc}")), protocol=5)
    raws = [b.raw() for b in buffers]
    _write_all(fd, struct.pack(f"<QQ{len(raws)}Q", len(head), len(raws), *[r.nbytes for r in raws]))
    _write_all(fd, head)
    for r in raws:
        _write_all(fd, r)


def _widen(fd: int) -> None:
    """A pipe of 1 MB where Linux allows (64 KB by default): a 40 MB answer
    in 40 round trips between the processes instead of 640."""
    import fcntl

    try:
        fcntl.fcntl(fd, getattr(fcntl, "F_SETPIPE_SZ", 1031), 1 << 20)
    except OSError:
        pass


def beside(fn: Callable[..., Any], *args: Any) -> Beside:
    """Runs ``fn(*args)`` in a forked process on a machine with more than
    one core; inline where there is one core or no fork. Either way
    ``result()`` returns the value or raises what ``fn`` raised. ``fn``'s
    result and exceptions must pickle; the caller should have no other
    threads running (it forks)."""
    if (os.cpu_count() or 1) > 1 and hasattr(os, "fork"):
        r, w = os.pipe()
        _widen(w)
        pid = os.fork()
        if pid == 0:  # the child: answer, then leave without running the caller's code
            status = 0
            try:
                os.close(r)
                _answer(w, fn, args)
            except BaseException:  # noqa: BLE001 - the parent sees the pipe end early
                status = 1
            finally:
                os._exit(status)
        os.close(w)
        return Beside(pid, r)
    try:
        return Beside(value=fn(*args))
    except Exception as exc:  # noqa: BLE001 - handed to the caller by result()
        return Beside(error=exc)


def read_frames_beside(log: str | Path) -> Beside:
    """:func:`.logfile.read_frames` of ``log`` beside the caller; pass the
    answer to :func:`stewart.analysis.analyze` as ``frames``."""
    from .logfile import read_frames

    return beside(read_frames, log)
