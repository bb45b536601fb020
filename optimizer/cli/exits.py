"""Exit statuses of every ``millfoil`` command (``docs/reference/errors.md``): a module of constants only, so
that the command line's entry point reads them before any heavy import."""

#: Success, bad input (configuration, override, file, a damaged store, a busy run directory), infeasible
#: blade, a stage failed.
EXIT_OK, EXIT_INPUT, EXIT_INFEASIBLE, EXIT_FAILED = 0, 2, 3, 4
#: An interrupted command (128 + SIGINT, as a shell reports Ctrl-C; SIGTERM too).
EXIT_INTERRUPTED = 130
#: The reader of the output went away (``millfoil status RUN | head``): 128 + SIGPIPE, as a shell reports a
#: tool that the closed pipe stopped.
EXIT_PIPE = 141
