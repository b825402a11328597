"""Savitzky-Golay wrapper, the per-class dispatch, and the [denoise] config tables."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from numpy.testing import assert_allclose

from gyrocomp.config import bind, load_config
from gyrocomp.denoise import DenoiseSettings, apply, savgol, tfpf
from gyrocomp.errors import InputError


def test_savgol_is_scipy_and_keeps_cubics():
    from scipy.signal import savgol_filter

    x = np.random.default_rng(0).standard_normal(300)
    assert_allclose(savgol(x, 51, 3), savgol_filter(x, 51, 3, mode="interp"))
    t = np.linspace(-1, 1, 200)
    cubic = 2 * t**3 - t + 0.5
    assert_allclose(savgol(cubic, 31, 3), cubic, atol=1e-10)


@pytest.mark.parametrize("args", [(50, 3), (5, 5), (51, -1)])
def test_savgol_bad_settings(args):
    with pytest.raises(InputError):
        savgol(np.arange(100.0), *args)


def test_savgol_too_short():
    with pytest.raises(InputError, match="shorter than the window"):
        savgol(np.arange(20.0), 51, 3)


@pytest.mark.parametrize("name", ["pe-lcd-anfis", "iceemdan-se-tfpf-nsga2elm"])
def test_defaults_equal_shipped_toml(name):
    table = load_config(name)["denoise"]
    settings = bind(DenoiseSettings, table, name)
    assert settings == dataclasses.replace(DenoiseSettings(), noise=settings.noise, mixed=settings.mixed)
    assert settings == DenoiseSettings() if name == "pe-lcd-anfis" else (settings.noise, settings.mixed) == ("tfpf_long", "tfpf_short")


def test_apply_per_class():
    rng = np.random.default_rng(4)
    comps = rng.standard_normal((3, 400))
    out = apply(comps, ["noise", "mixed", "drift"])
    assert_allclose(out[0], 0)
    assert_allclose(out[1], savgol(comps[1], 51, 3))
    assert_allclose(out[2], comps[2])
    settings = DenoiseSettings(noise="tfpf_long", mixed="tfpf_short")
    out = apply(comps, [{"class": "noise"}, {"class": "mixed"}, {"class": "drift"}], settings)
    assert_allclose(out[0], tfpf(comps[0], 101))
    assert_allclose(out[1], tfpf(comps[1], 21))


def test_apply_bad_input():
    with pytest.raises(InputError, match="2 classes for 3"):
        apply(np.zeros((3, 10)), ["noise", "drift"])
    with pytest.raises(InputError, match="class 'feature'"):
        apply(np.zeros((1, 10)), ["feature"])
    with pytest.raises(InputError):
        bind(DenoiseSettings, {"noise": "median"}, "test")
