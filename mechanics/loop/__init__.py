"""The compiled time loop: the constants it reads, its state layout, the speed input, one right-hand side, the step
loop and its methods, what it records per step and per lobe, and its cost said up front (docs/model.md §3.2, §8)."""
