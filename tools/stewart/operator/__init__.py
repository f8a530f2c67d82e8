# SPDX-License-Identifier: Apache-2.0
"""The operator's side: an operator node on any bus python-can opens.

- :mod:`.bus` opens the bus with python-can's conventions;
- :mod:`.node` is the interface-agnostic operator node: heartbeat,
  commands that wait for the controller's answer, the controller's status
  and monitor frames, bus counters;
- :mod:`.sources` are the pose sources of ``stewart op stream``: a
  timestamped CSV file and UDP datagrams (poses, or vehicle telemetry for
  motion cueing).
"""
