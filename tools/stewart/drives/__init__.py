# SPDX-License-Identifier: Apache-2.0
"""CANopen drives (CiA 408 servo valves and hydraulic axis controllers, CiA 402
electric drives): what the controller's CANopen master needs from a drive
(:mod:`.objects`, the one list), the bus load of a layout (:mod:`.layout`),
an EDS checked against the list (:mod:`.eds`), and the PC-side commissioning
over the ``canopen`` library (:mod:`.session`). docs/reference/canopen.md has the design.

:mod:`.objects` and :mod:`.layout` use the standard library only (the platform
config and, later, the firmware generator read them before any venv exists).
"""
