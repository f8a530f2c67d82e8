# SPDX-License-Identifier: Apache-2.0
"""Sub-commands of ``stewart``: one module each, each with ``register(subparsers)``."""
