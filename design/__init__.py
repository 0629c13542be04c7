"""design: see ARCHITECTURE.md (filled by later issues)."""
