"""configs/diagnose.toml is the one settings tree of the diagnosis: every key once, equal to the defaults."""

import dataclasses

import pytest

from gyrocomp.config import load_config
from gyrocomp.diagnose import DiagnoseSettings, get_config
from gyrocomp.diagnose.settings import MOVED
from gyrocomp.errors import InputError


def _leaves(settings, prefix="diagnose"):
    """``(dotted path, default)`` of every leaf field of the tree under `settings`."""
    for f in dataclasses.fields(settings):
        value = getattr(settings, f.name)
        if dataclasses.is_dataclass(value):
            yield from _leaves(value, f"{prefix}.{f.name}")
        else:
            yield f"{prefix}.{f.name}", value


def _toml_leaves(table, prefix="diagnose"):
    for key, value in table.items():
        if isinstance(value, dict):
            yield from _toml_leaves(value, f"{prefix}.{key}")
        else:
            yield f"{prefix}.{key}", tuple(value) if isinstance(value, list) else value


def test_no_key_appears_twice_in_the_tree():
    names = [path.rsplit(".", 1)[1] for path, _ in _leaves(DiagnoseSettings())]
    twice = sorted({n for n in names if names.count(n) > 1})
    assert not twice, f"keys defined twice in the settings tree: {twice}"


def test_every_default_equals_the_shipped_config():
    shipped = dict(_toml_leaves(load_config("diagnose")["diagnose"]))
    defaults = dict(_leaves(DiagnoseSettings()))
    assert set(shipped) == set(defaults)
    for path, value in defaults.items():
        assert shipped[path] == value and type(shipped[path]) is type(value), path
    assert get_config() == DiagnoseSettings()


def test_the_shipped_config_is_the_only_diagnose_config():
    # the layout before the tree kept [signature] and [unexplained] in configs/unexplained.toml
    with pytest.raises(InputError, match="no such config"):
        load_config("unexplained")


def test_every_moved_key_has_its_new_place():
    leaves = dict(_leaves(DiagnoseSettings()))
    assert all(new in leaves for new in MOVED.values())


@pytest.mark.parametrize(("old", "text"), [
    ("[unexplained]\nwhiteness_lags = 10\n", "`unexplained.whiteness_lags` moved to `diagnose.checks.ljung_box_lags`"),
    ("[signature]\nfamily_alpha = 0.01\n", "`signature.family_alpha` moved to `diagnose.signature.refusal_alpha`"),
    ("[diagnose]\nsoak_rate_c_per_min = 0.1\n", "`diagnose.soak_rate_c_per_min` moved to `diagnose.checks.soak_rate_c_per_min`"),
])
def test_a_config_of_the_old_layout_names_the_moved_key(tmp_path, old, text):
    path = tmp_path / "old.toml"
    path.write_text(old, encoding="utf-8")
    with pytest.raises(InputError) as err:
        get_config(path)
    assert text in str(err.value) and "\n" not in str(err.value)


def test_a_section_is_read_from_its_table(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text("[diagnose]\nbic_margin = 12.0\n[diagnose.checks]\nljung_box_lags = 12\n[diagnose.confirm]\nsteady_segments = 3\n", encoding="utf-8")
    got = get_config(path)
    assert (got.bic_margin, got.checks.ljung_box_lags, got.confirm.steady_segments) == (12.0, 12, 3)
    assert got.checks.temperature_bins == DiagnoseSettings().checks.temperature_bins
    path.write_text("[diagnose.checks]\nno_such_key = 1\n", encoding="utf-8")
    with pytest.raises(InputError, match="no_such_key"):
        get_config(path)


def test_bad_setting_is_refused():
    with pytest.raises(InputError, match="poly_degree"):
        DiagnoseSettings(poly_degree=4)
