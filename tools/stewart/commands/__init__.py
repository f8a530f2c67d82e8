"""Sub-commands of ``stewart``: one module each, each with ``register(subparsers)``."""
