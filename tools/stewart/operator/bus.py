# SPDX-License-Identifier: Apache-2.0
"""Opening the operator's bus with python-can's conventions.

The interface, channel and bit rates come from the command line
(``--interface``, ``--channel``, ``--bitrate``, ``--data-bitrate``,
``--fd``); what is not given there comes from python-can's own
configuration (``CAN_INTERFACE``, ``CAN_CHANNEL``, ``CAN_BITRATE`` and
``CAN_CONFIG`` in the environment, ``~/.canrc``, ``~/.can``,
``/etc/can.conf``, or ``can.ini`` / ``.canrc`` in the working directory
with ``--can-config FILE``, section ``[default]`` or ``--context``); with
nothing configured, SocketCAN on ``vcan0`` (the ops bus of the simulated
set-up). The protocol is CAN FD with bit-rate switch: ``fd`` is on unless
``--no-fd`` or the configuration says ``fd = False``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


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


def resolve(opts: BusOptions) -> dict[str, Any]:
    """The keyword arguments for ``can.Bus``: the options given, then
    python-can's configuration, then the defaults (socketcan, vcan0, FD)."""
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
    if cfg.get("channel") in (None, "") and cfg["interface"] == "socketcan":
        cfg["channel"] = "vcan0"
    if "fd" not in cfg:
        cfg["fd"] = True
    return cfg


def open_bus(opts: BusOptions, receive_own_messages: bool = False):
    """Opens the bus; raises :class:`BusError` with a clear message."""
    import can

    kwargs = resolve(opts)
    interface = kwargs["interface"]
    if interface not in can.VALID_INTERFACES:
        known = ", ".join(sorted(can.VALID_INTERFACES))
        raise BusError(f"unknown interface {interface!r} (python-can knows: {known})")
    try:
        return can.Bus(receive_own_messages=receive_own_messages, **kwargs)
    except can.CanInterfaceNotImplementedError as e:
        raise BusError(f"interface {interface!r} is not usable here: {e}") from None
    except (can.CanError, OSError, ValueError, TypeError, ImportError) as e:
        channel = kwargs.get("channel")
        raise BusError(f"cannot open {interface} channel {channel!r}: {e}") from None


def describe(bus) -> str:
    return str(getattr(bus, "channel_info", "") or type(bus).__name__)
