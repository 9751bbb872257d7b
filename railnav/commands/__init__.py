"""The command-line layer: one module per ``railnav`` subcommand.

Each module defines ``register(subparsers)``, which adds its parser and sets
``func=handler``; a handler takes the parsed arguments and returns the exit status.
Handlers only translate arguments into the public API of `railnav` (and the library
packages) and results into files; they hold no physics. `railnav.cli` assembles them.
"""
