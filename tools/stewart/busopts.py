# SPDX-License-Identifier: Apache-2.0
"""The CAN bus options of every command that opens a bus, with python-can's
conventions.

:func:`add_arguments` gives a command ``-i/--interface``, ``-c/--channel``,
``-b/--bitrate``, ``--fd``/``--no-fd``, ``--data-bitrate``,
``--can-config FILE`` and ``--context SECTION``; :func:`options` reads them
back and :func:`open_bus` opens the bus. What the command line does not give
comes from python-can's own configuration (``CAN_INTERFACE``,
``CAN_CHANNEL``, ``CAN_BITRATE`` and ``CAN_CONFIG`` in the environment,
``~/.canrc``, ``~/.can``, ``/etc/can.conf``, or ``can.ini`` / ``.canrc`` in
the working directory, the file of ``--can-config``, section ``[default]``
or ``--context``). With nothing configured: SocketCAN on the simulated
set-up's interface of the bus the command talks to (:data:`BUSES`: ops
vcan0, axis_a vcan1, axis_b vcan2), CAN FD on the ops bus (the protocol
needs it), classic CAN on a CANopen drive bus. With ``-i socketcand`` and
no host or port: ``stewart sim``'s server, 127.0.0.1 port 29536, the same
channel names (docs/guides/simulator.md).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from typing import Any

from .protocol import BUSES


#: python-can's socketcand interface without a host or port: `stewart sim`'s
#: server on loopback (docs/guides/simulator.md).
SOCKETCAND_HOST = "127.0.0.1"
SOCKETCAND_PORT = 29536


class BusError(Exception):
    """The bus could not be opened (message for the user)."""


@dataclass
class BusOptions:
    interface: str | None = None
    channel: str | None = None
    bitrate: int | None = None
    data_bitrate: int | None = None
    fd: bool | None = None
    config_file: str | None = None
    context: str | None = None
    #: the bus the command talks to (ops, axis_a, axis_b): its default channel
    bus: str = "ops"
    #: CAN FD unless the options or the configuration say otherwise
    fd_default: bool = True


def add_arguments(parser: argparse.ArgumentParser, bus: str = "ops", fd: bool = True) -> None:
    """The bus options of a command that talks to ``bus`` (CAN FD by default
    when ``fd``)."""
    g = parser.add_argument_group("CAN bus (python-can's options and configuration)")
    g.add_argument("-i", "--interface", help="python-can interface (default: python-can's configuration, "
                   "else socketcan)")
    g.add_argument("-c", "--channel", help=f"channel (default: python-can's configuration, else {BUSES[bus]}, "
                   f"the simulated set-up's {bus} bus)")
    g.add_argument("-b", "--bitrate", type=int, help="nominal (arbitration) bit rate, bit/s")
    g.add_argument("--data-bitrate", type=int, help="CAN FD data-phase bit rate, bit/s")
    kind = g.add_mutually_exclusive_group()
    kind.add_argument("--fd", dest="fd", action="store_true", default=None,
                      help="CAN FD" + (" (the default)" if fd else ""))
    kind.add_argument("--no-fd", dest="fd", action="store_false",
                      help="classic CAN" + ("" if fd else " (the default)"))
    g.add_argument("--can-config", metavar="FILE", help="python-can configuration file")
    g.add_argument("--context", help="section of the python-can configuration file")
    parser.set_defaults(bus_name=bus, bus_fd_default=fd)


def options(args: argparse.Namespace) -> BusOptions:
    """The bus options :func:`add_arguments` put on the command line."""
    return BusOptions(args.interface, args.channel, args.bitrate, args.data_bitrate, args.fd,
                      args.can_config, args.context, args.bus_name, args.bus_fd_default)


def resolve(opts: BusOptions) -> dict[str, Any]:
    """The keyword arguments for ``can.Bus``: the options given, then
    python-can's configuration, then the defaults (socketcan, the bus's
    vcan interface, FD as the bus needs)."""
    import can
    import can.util

    given: dict[str, Any] = {}
    for key in ("interface", "channel", "bitrate", "data_bitrate"):
        v = getattr(opts, key)
        if v is not None:
            given[key] = v
    if opts.fd is not None:
        given["fd"] = opts.fd
    cfg: dict[str, Any] = {}
    try:
        cfg = dict(can.util.load_config(path=opts.config_file, config=dict(given), context=opts.context))
    except can.CanInterfaceNotImplementedError:
        cfg = dict(given)  # nothing configured: the defaults below
    except (ValueError, KeyError, OSError) as e:
        raise BusError(f"python-can configuration: {e}") from None
    if not cfg.get("interface"):
        cfg["interface"] = "socketcan"
    if cfg.get("channel") in (None, "") and cfg["interface"] in ("socketcan", "socketcand"):
        cfg["channel"] = BUSES[opts.bus]
    if cfg["interface"] == "socketcand":  # `stewart sim`'s server on loopback unless configured
        cfg.setdefault("host", SOCKETCAND_HOST)
        cfg["port"] = int(cfg.get("port", SOCKETCAND_PORT))
    if "fd" not in cfg:
        cfg["fd"] = opts.fd_default
    return cfg


def check_interface(kwargs: dict[str, Any]) -> None:
    """BusError unless python-can knows the interface."""
    import can

    interface = kwargs["interface"]
    if interface not in can.VALID_INTERFACES:
        known = ", ".join(sorted(can.VALID_INTERFACES))
        raise BusError(f"unknown interface {interface!r} (python-can knows: {known})")


def _check_socketcand(kwargs: dict[str, Any]) -> None:
    """A clear error at once where no server listens (python-can's client
    retries for 10 s, logging each try); its warnings about messages split
    across reads (normal on TCP) kept quiet."""
    import logging
    import socket

    logging.getLogger("can.interfaces.socketcand.socketcand").setLevel(logging.ERROR)
    host, port = kwargs.get("host"), kwargs.get("port")
    try:
        socket.create_connection((host, port), timeout=2.0).close()
    except (OSError, TypeError, ValueError) as e:
        raise BusError(f"no socketcand server at {host}:{port} ({e}); is `stewart sim` running "
                       f"(docs/guides/simulator.md)?") from None


def _mark_fd(bus) -> None:
    """python-can's socketcand client marks no frame CAN FD (it carries
    their 64 bytes all the same): on a CAN FD bus every frame received is
    marked CAN FD with bit-rate switch, as the bus sent it, so that a
    recording writes CAN FD frames (candump ``##``) that `stewart analyze`
    reads."""
    receive = bus._recv_internal

    def recv_internal(timeout):
        msg, filtered = receive(timeout)
        if msg is not None:
            msg.is_fd = True
            msg.bitrate_switch = True
        return msg, filtered

    bus._recv_internal = recv_internal


def open_bus(opts: BusOptions, receive_own_messages: bool = False):
    """Opens the bus; raises :class:`BusError` with a clear message."""
    import can

    kwargs = resolve(opts)
    check_interface(kwargs)
    interface = kwargs["interface"]
    fd_marks = False
    if interface == "socketcand":
        _check_socketcand(kwargs)
        fd_marks = bool(kwargs.pop("fd", False))
    try:
        bus = can.Bus(receive_own_messages=receive_own_messages, **kwargs)
        if fd_marks:
            _mark_fd(bus)
        return bus
    except can.CanInterfaceNotImplementedError as e:
        raise BusError(f"interface {interface!r} is not usable here: {e}") from None
    except (can.CanError, OSError, ValueError, TypeError, ImportError) as e:
        channel = kwargs.get("channel")
        raise BusError(f"cannot open {interface} channel {channel!r}: {e}") from None
