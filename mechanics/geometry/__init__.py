"""The machine's shape and the vane's motion in it: displacement laws, pitch curve and stator, the vane's pose, the
chamber volumes (docs/model.md §2, §3.1, §3.4, §7.2)."""
