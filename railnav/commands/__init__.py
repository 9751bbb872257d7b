"""The command-line layer: one module per ``railnav`` subcommand.

Each module defines ``register(subparsers)``, which adds its parser and sets
``func=handler``; a handler takes the parsed arguments and returns the exit status.
Handlers only translate arguments into the public API of `railnav` (and the library
packages) and results into files; they hold no physics. `railnav.cli` assembles them.

Start-up: the parser of every subcommand is built for any ``railnav`` call, so a module
imports at its top only what its parser needs (constants from light owner modules such as
`railnav.defaults`), and each handler imports the machinery it runs: ``railnav --help``
and an argument error import neither CasADi, SciPy nor pandas
(``tests/railnav/commands/test_cli_startup.py``).
"""
