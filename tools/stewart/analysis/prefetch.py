"""Reading a run's inputs beside each other. A log's frames
(:func:`.logfile.read_frames`, numpy only) and the plant's truth CSV do not
need the protocol; reading them in a forked process while the caller loads
the DBC and decodes puts the machine's second core to work. This module
imports nothing heavy, so that the log can be started on before the
protocol is loaded (``stewart analyze`` does so)."""

from __future__ import annotations

import multiprocessing
import os
from concurrent.futures import Future, ProcessPoolExecutor
from pathlib import Path
from typing import Any, Callable


def beside(fn: Callable[..., Any], *args: Any) -> Future:
    """Runs ``fn(*args)`` in a forked process on a machine with more than
    one core; inline where there is one core or no fork. Either way
    ``result()`` returns the value or raises what ``fn`` raised. ``fn`` and
    its result must pickle."""
    if (os.cpu_count() or 1) > 1 and "fork" in multiprocessing.get_all_start_methods():
        pool = ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("fork"))
        fut = pool.submit(fn, *args)
        pool.shutdown(wait=False)  # the worker ends once its one job is done
        return fut
    fut: Future = Future()
    try:
        fut.set_result(fn(*args))
    except Exception as exc:  # noqa: BLE001 - handed to the caller by result()
        fut.set_exception(exc)
    return fut


def read_frames_beside(log: str | Path) -> Future:
    """:func:`.logfile.read_frames` of ``log`` beside the caller; pass the
    future to :func:`stewart.analysis.analyze` as ``frames``."""
    from .logfile import read_frames

    return beside(read_frames, log)
