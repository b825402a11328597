"""configs/diagnose.toml equals the defaults of DiagnoseSettings."""

import dataclasses

import pytest

from gyrocomp.diagnose import DiagnoseSettings, get_config
from gyrocomp.errors import InputError


def test_shipped_config_equals_defaults():
    assert get_config() == DiagnoseSettings()
    fields = {f.name for f in dataclasses.fields(DiagnoseSettings)}
    from gyrocomp.config import load_config

    assert set(load_config("diagnose")["diagnose"]) == fields


def test_bad_setting_is_refused():
    with pytest.raises(InputError, match="poly_degree"):
        DiagnoseSettings(poly_degree=4)
