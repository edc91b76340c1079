"""excavsim.learning: see shared/DESIGN.md §2 (filled by later issues)."""
