"""windnav.experiments (see DESIGN.md)."""
