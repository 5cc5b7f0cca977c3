"""What a run shows the person at the terminal: warnings as one line (in its process and in its
workers'), progress bars that start no thread, and figures written and closed."""

from __future__ import annotations

import functools
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


@functools.cache
def _bar_class(auto: bool):
    """tqdm's bar (``tqdm.auto``'s, a notebook widget in Jupyter, or the terminal's) without its
    monitor thread (``monitor_interval = 0``)."""
    if auto:
        from tqdm.auto import tqdm
    else:
        from tqdm import tqdm
    return type("ProgressBar", (tqdm,), {"monitor_interval": 0, "__module__": __name__})


def progress_bar(*args, auto: bool = True, **kwargs):
    """A tqdm progress bar (same arguments, ``disable=True`` for none) that starts no thread.

    tqdm starts a monitor thread with its first bar, even a disabled one, and keeps it for the
    life of the process: a program calling ``windnav.sim.fly`` (``progress=False``) became
    multi-threaded, which a later ``fork`` can deadlock on (side-effects audit, thirty-seventh
    session). The monitor only shortens the refresh of bars that stall, which these do not
    need. ``auto``: ``tqdm.auto`` (a widget in notebooks) rather than the terminal's bar.
    """
    return _bar_class(auto)(*args, **kwargs)


def save_and_close(fig, path, **savefig_kwargs) -> None:
    """``fig.savefig(path, **savefig_kwargs)``, then ``plt.close(fig)`` even when the write
    fails (a missing folder, a full disk): a failed figure stayed open in pyplot's registry
    for the life of the process (side-effects audit, thirty-seventh session)."""
    import matplotlib.pyplot as plt

    try:
        fig.savefig(path, **savefig_kwargs)
    finally:
        plt.close(fig)


def closes_figures_on_error(plot):
    """Decorator: the pyplot figures that ``plot`` opened are closed when it raises (a failure
    after ``plt.subplots``, such as a flight shorter than ``plot_wind_track``'s settling time,
    left its figure open: about 1 MB a failed call, for the life of the process; leak audit,
    thirty-seventh session). On success the function closes what it writes, as before."""
    @functools.wraps(plot)
    def closing(*args, **kwargs):
        import matplotlib.pyplot as plt

        before = set(plt.get_fignums())
        try:
            return plot(*args, **kwargs)
        except BaseException:
            for number in set(plt.get_fignums()) - before:
                plt.close(number)
            raise

    return closing
