"""windnav.sim (see DESIGN.md)."""
