"""windnav.estimate (see DESIGN.md)."""
