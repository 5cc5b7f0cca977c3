"""windnav.commands (see DESIGN.md)."""
