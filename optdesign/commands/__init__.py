"""One module per ``optdesign`` sub-command; the CLI lists them in ``optdesign.cli.COMMANDS``."""
