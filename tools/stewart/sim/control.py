# SPDX-License-Identifier: Apache-2.0
"""The control socket of a running ``stewart sim``: a Unix stream socket
(mode 600) in its run directory. One request a connection: a JSON line
``{"op": "status"}``, ``{"op": "inject", "line": "push 0 0 300 0 0 0 rise=0.2 hold=1"}``
or ``{"op": "stop"}``; one JSON line back, with ``ok`` and, when not ok,
``answer`` (why)."""

from __future__ import annotations

import json
import os
import socket
import threading
from pathlib import Path
from typing import Callable

MAX_REQUEST = 4096


class ControlError(RuntimeError):
    """No simulation answers there (message for the user)."""


class Server:
    """Serves ``handle(request) -> reply`` on ``path`` in a thread."""

    def __init__(self, path: Path, handle: Callable[[dict], dict]):
        self.path, self.handle = Path(path), handle
        if self.path.exists() or self.path.is_symlink():
            if _answers(self.path):
                raise ControlError(f"a simulation already runs with the control socket {self.path} "
                                   "(stewart sim stop, or --run-dir elsewhere)")
            self.path.unlink()
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        old = os.umask(0o177)
        try:
            self.sock.bind(str(self.path))
        finally:
            os.umask(old)
        self.sock.listen(8)
        threading.Thread(target=self._accept, daemon=True).start()

    def close(self) -> None:
        self.sock.close()
        try:
            self.path.unlink()
        except OSError:
            pass

    def _accept(self) -> None:
        while True:
            try:
                conn, _ = self.sock.accept()
            except OSError:
                return
            threading.Thread(target=self._serve, args=(conn,), daemon=True).start()

    def _serve(self, conn: socket.socket) -> None:
        with conn:
            conn.settimeout(10)
            try:
                data = b""
                while b"\n" not in data and len(data) < MAX_REQUEST:
                    chunk = conn.recv(MAX_REQUEST)
                    if not chunk:
                        break
                    data += chunk
                try:
                    req = json.loads(data.split(b"\n", 1)[0])
                    if not isinstance(req, dict):
                        raise ValueError
                except ValueError:
                    reply = {"ok": False, "answer": "a request is one JSON object on a line"}
                else:
                    reply = self.handle(req)
                conn.settimeout(60)
                conn.sendall((json.dumps(reply) + "\n").encode())
            except OSError:
                pass


def _answers(path: Path) -> bool:
    try:
        call(path, {"op": "status"}, timeout=2.0)
        return True
    except ControlError:
        return False


def call(path: Path, request: dict, timeout: float = 30.0) -> dict:
    """Sends one request to the simulation's control socket; its reply."""
    s = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    s.settimeout(timeout)
    try:
        s.connect(str(path))
        s.sendall((json.dumps(request) + "\n").encode())
        data = b""
        while not data.endswith(b"\n"):
            chunk = s.recv(65536)
            if not chunk:
                break
            data += chunk
    except FileNotFoundError:
        raise ControlError(f"no simulation runs here (no control socket {path}; start one with stewart sim)") from None
    except (ConnectionRefusedError, socket.timeout, OSError) as e:
        raise ControlError(f"the simulation at {path} does not answer ({e})") from None
    finally:
        s.close()
    try:
        return json.loads(data)
    except ValueError:
        raise ControlError(f"the simulation at {path} answered no JSON") from None
