"""windnav.viz (see DESIGN.md)."""
