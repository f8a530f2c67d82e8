# SPDX-License-Identifier: Apache-2.0
"""``stewart sim``: the simulated platform, running until stopped.

The firmware's controller (``sp_controller``, host build) and the simulated
hexapod (``hs_sim``) run in real time on three vcan buses: the host's where
its kernel has vcan, else inside a user-mode Linux (UML). Programs on the
host reach the buses

- as SocketCAN (``vcan0``..``vcan2``) where the host has vcan;
- through python-can's ``socketcand`` interface on 127.0.0.1 (a small
  server in this process, :mod:`stewart.sim.bridge`), the frames carried
  into the UML over one of its console channels (:mod:`stewart.sim.wire`)
  by an agent there (:mod:`stewart.sim.agent`);

and the running simulation through a control socket (a Unix socket:
``stewart sim inject|status|stop``). Guide: docs/guides/simulator.md.

Modules: :mod:`~stewart.sim.wire` (the link's lines), :mod:`~stewart.sim.plant`
(the two processes), :mod:`~stewart.sim.agent` (their side of the link),
:mod:`~stewart.sim.bridge` (the socketcand server), :mod:`~stewart.sim.host`
(the ``stewart sim`` process), :mod:`~stewart.sim.control` (the control socket).
"""
