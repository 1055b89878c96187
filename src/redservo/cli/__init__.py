"""The ``redservo`` command line: the parser, one module per command group."""
