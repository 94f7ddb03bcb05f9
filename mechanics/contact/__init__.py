"""Contact: the regions' table, their detection, the force laws, the forces and their reactions, the contact modes
(docs/model.md §1.3, §4, §5)."""
