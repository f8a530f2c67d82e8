# SPDX-License-Identifier: Apache-2.0
"""Geometric calibration of the machine as built (``stewart calibrate``):
plan, run, solve, check (docs/guides/commissioning.md)."""
