"""windnav.wind (see DESIGN.md)."""
