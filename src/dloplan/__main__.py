"""``python -m dloplan``: the console script (:mod:`dloplan.console`)."""

from .console import run

if __name__ == "__main__":
    run()
