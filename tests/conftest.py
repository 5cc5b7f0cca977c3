"""Figures drawn by the tests go to files: the non-interactive backend, whatever the display
(the plotting modules leave the backend to their user)."""

import os

os.environ.setdefault("MPLBACKEND", "Agg")
