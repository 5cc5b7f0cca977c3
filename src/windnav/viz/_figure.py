"""Writing a pyplot figure and closing it, whether or not the write succeeds."""

from __future__ import annotations

import matplotlib.pyplot as plt


def save_and_close(fig, path, **savefig_kwargs) -> None:
    """``fig.savefig(path, **savefig_kwargs)``, then ``plt.close(fig)`` even when the write
    fails (a missing folder, a full disk): a failed figure stayed open in pyplot's registry
    for the life of the process (side-effects audit, thirty-seventh session)."""
    try:
        fig.savefig(path, **savefig_kwargs)
    finally:
        plt.close(fig)
