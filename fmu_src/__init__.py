"""FMI 2.0 co-simulation slaves (the compressor and a motor) and the build that writes the .fmu files.

Thin by design: maps FMI calls onto `mechanics.Simulation`; no physics here.
"""
