"""Importing this module warms matplotlib for a plan's figures (:func:`.worker.warm_up`).

It is the preload of the server process the figure workers are forked from
(:mod:`dloplan.app.figure_workers`): imported once there, every worker forked from the server
starts with matplotlib imported and its fonts and backends loaded. The server then ends
without the interpreter's teardown when the command has ended (as the command itself,
:func:`dloplan.cli.run`): it shares the command's output streams, and a caller reading them to
their end is not kept waiting for matplotlib and numpy to be freed (about 0.3 s). Import it
nowhere else.
"""

import atexit
import os

from .worker import warm_up

warm_up()
atexit.register(os._exit, 0)
