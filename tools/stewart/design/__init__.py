# SPDX-License-Identifier: Apache-2.0
"""``stewart design``: the designer's tool (workspace, forces, hydraulics,
stiffness, sweeps) over the float64 model."""
