"""``python -m dloplan``: the console script (:mod:`dloplan.console`)."""

from .console import run

run()
