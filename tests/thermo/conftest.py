"""Fixtures of the thermo tests: a table cache folder per module, and tables built once per module and fluid."""
import pytest

from rotary_vane.thermo.fluid import Fluid
from rotary_vane.thermo.property_table import envelope_for


@pytest.fixture(scope="module")
def cache_dir(tmp_path_factory, request):
    """An empty table cache folder for the module (tables built in it are reused by its tests)."""
    return tmp_path_factory.mktemp(request.module.__name__.removeprefix("test_"))


@pytest.fixture(scope="module")
def tables_for(cache_dir):
    """tables_for(build, operating_point) -> get(name): (fluid, envelope, build(fluid, envelope, cache_dir=...)),
    the envelope around `operating_point(fluid)`, built on first use and memoised for the module."""
    def tables(build, operating_point):
        built = {}

        def get(name):
            if name not in built:
                fluid = Fluid(name)
                envelope = envelope_for(fluid, *operating_point(fluid))
                built[name] = (fluid, envelope, build(fluid, envelope, cache_dir=cache_dir))
            return built[name]
        return get
    return tables
