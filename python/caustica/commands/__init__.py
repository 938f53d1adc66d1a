"""Commands of the command line that live in their own modules (see cli.COMMAND_MODULES)."""
