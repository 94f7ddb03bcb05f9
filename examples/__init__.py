"""Scripts users copy (fmpy harnesses, studies, animations, campaigns) and the helpers they share, importable as
`rotary_vane.examples` (e.g. `from rotary_vane.examples.campaign import run_campaign`); each script also runs as
`python examples/NAME.py`."""
