"""Plots and figures (matplotlib, Agg backend)."""
