"""Command-line subcommands, one module each (see mjxmimic.cli)."""
