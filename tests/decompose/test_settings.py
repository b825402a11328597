"""DecomposeSettings: defaults equal the shipped configs; bad values refused."""

import dataclasses

import pytest

from gyrocomp import config
from gyrocomp.decompose import DecomposeSettings, decompose
from gyrocomp.errors import InputError


@pytest.mark.parametrize("name", ["pe-lcd-anfis", "iceemdan-se-tfpf-nsga2elm"])
def test_defaults_equal_shipped_toml(name):
    table = config.load_config(name)["decompose"]
    bound = config.bind(DecomposeSettings, table, name)
    assert set(table) == {f.name for f in dataclasses.fields(DecomposeSettings)}
    assert bound == dataclasses.replace(DecomposeSettings(), method=table["method"])


def test_pe_lcd_method_is_the_default():
    assert config.load_config("pe-lcd-anfis")["decompose"]["method"] == DecomposeSettings().method


@pytest.mark.parametrize("bad", [{"method": "vmd"}, {"ensemble": 0}, {"q": 1.5}, {"stop": "x"}, {"thresholds": [0.1]}])
def test_bad_settings(bad):
    with pytest.raises(InputError):
        config.bind(DecomposeSettings, bad, "test")


def test_bad_signal():
    with pytest.raises(InputError, match="finite"):
        decompose([0.0, 1.0, float("nan"), 2.0, 3.0])
    with pytest.raises(InputError, match="at least 4"):
        decompose([1.0, 2.0])
