"""windnav.flow (see DESIGN.md)."""
