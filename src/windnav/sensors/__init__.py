"""windnav.sensors (see DESIGN.md)."""
