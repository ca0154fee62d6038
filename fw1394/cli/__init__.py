"""The ``fw1394`` command (:func:`fw1394.cli.main.main`): one module per subcommand.

Not a library API: programs use the packages below it. Run ``fw1394 --help``.
"""

__all__: list[str] = []
