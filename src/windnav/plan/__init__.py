"""windnav.plan (see DESIGN.md)."""
