"""The ``urmx`` subcommands, one module each with ``register(subparsers)`` (`urmx.cli`
registers them)."""
