"""Reduced and companion models built on the detailed one, not vane mechanics: periodic-map tables, AHRI 540 rating
maps, the drive motor (docs/model.md §12, README "Periodic map", "Rating maps")."""
