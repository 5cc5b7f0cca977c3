"""windnav.predict (see DESIGN.md)."""
