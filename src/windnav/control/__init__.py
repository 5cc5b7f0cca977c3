"""windnav.control (see DESIGN.md)."""
