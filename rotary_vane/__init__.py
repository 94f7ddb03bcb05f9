"""rotary-vane-compressor: one import package that owns the project's folders.

The repository keeps the design card's folders at its top (`thermo/`, `mechanics/`, `fmu_src/`); the installed
distribution maps them to `rotary_vane.thermo`, `rotary_vane.mechanics` and `rotary_vane.fmu_src`
(`[tool.setuptools.package-dir]` in pyproject.toml), so that nothing this project installs can overwrite or be
shadowed by another distribution's `thermo` or `mechanics` (PyPI has a widely used `thermo`).
"""
