"""Exit codes of the ``dloplan`` command (a module of its own, light to import)."""

EXIT_OK, EXIT_WARNINGS, EXIT_FAILURE, EXIT_CHECK_FAILED = 0, 1, 2, 3
"""Exit codes: success; success with warnings; bad input or a job that cannot be planned
(nothing written); planned, but a check failed (the plan document and the report are written
for inspection, no robot program or trajectory)."""
EXIT_INTERRUPTED = 130
"""Ctrl-C: nothing written. Every signal that ends a run gives ``128 + signal`` (SIGTERM 143,
SIGHUP 129; :func:`dloplan.interrupts.exit_code`)."""
