"""How the command line prints warnings: one line, in its process and in its workers'."""

from __future__ import annotations

import sys


def one_line_warning(where: str):
    """A ``warnings.showwarning`` that prints ``<where>: warning: message`` on stderr (Python's
    default adds the file, the line number and the source line). Its ``where`` attribute lets
    the process workers of :func:`windnav.experiments.run_tasks` print alike (the serial
    backend did; a worker printed Python's three-line form)."""
    def show(message, category, filename, lineno, file=None, line=None):
        text = " ".join(str(message).split())
        print(f"{where}: warning: {text}", file=sys.stderr if file is None else file)

    show.where = where
    return show
