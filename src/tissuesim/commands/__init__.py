"""Sub-commands of the ``tissuesim`` CLI, one module each.

Each module defines ``HELP`` (one line), ``add_arguments(parser)`` and ``run(args) -> int``.
"""
