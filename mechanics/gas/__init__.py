"""What the vane mechanics reads of the gas: the gas loads on vane, rotor and stator, the chamber pressure source of
Levels 0 and 0.5 and the coupling to each pressure model (docs/model.md §6, §7)."""
