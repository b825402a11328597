"""PX4 and ArduPilot parameters, evaluated with the firmwares' published formulas, equal causal compensation.

The formulas here are written from the firmware sources, independently of
gyrocomp.export:

* PX4 ``TemperatureCompensation::calc_thermal_offsets_3D``: ``dT = clamp(T,
  TMIN, TMAX) - TREF``; ``offset = X0 + X1 dT + X2 dT^2 + X3 dT^3`` [rad/s];
  ``Gyroscope::Correct``: ``data - thermal_offset - offset``.
* ArduPilot ``AP_InertialSensor::TCal::correct_sensor``: ``v -= P(clamp(T) -
  35); v += P(clamp(cal_temp) - 35)``, ``P(x) = (c1 + (c2 + c3 x) x) x * 1e-6``
  [rad/s]; the backend then subtracts ``INS_GYROFFS``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gyrocomp.export import ExportOptions, export_model
from gyrocomp.pipeline.compensate import compensate, load_model

DEG = 180.0 / math.pi


def _px4_table(text):
    params = {}
    for line in text.splitlines():
        if line.startswith("#") or not line.strip():
            continue
        vehicle, component, name, value, kind = line.split("\t")
        assert (vehicle, component) == ("1", "1") and kind in ("6", "9")
        params[name] = int(value) if kind == "6" else float(value)
    return params


def _parm_table(text):
    params = {}
    for line in text.splitlines():
        if line.startswith("#") or not line.strip():
            continue
        name, value = line.split()
        assert "e" not in value.lower()  # ArduPilot scales its coefficients so that no exponent is needed
        params[name] = float(value)
    return params


def px4_corrected(raw_rad_s, temperature, p, i=0, axis=0):
    t = np.clip(temperature, p[f"TC_G{i}_TMIN"], p[f"TC_G{i}_TMAX"])
    d = t - p[f"TC_G{i}_TREF"]
    offset = sum(p[f"TC_G{i}_X{k}_{axis}"] * d**k for k in range(4))
    return raw_rad_s - offset


def ardupilot_corrected(raw_rad_s, temperature, p, n=1, axis="X"):
    lo, hi = p[f"INS_TCAL{n}_TMIN"], p[f"INS_TCAL{n}_TMAX"]
    c = [p[f"INS_TCAL{n}_GYR{k}_{axis}"] for k in (1, 2, 3)]

    def poly(x):
        return (c[0] + (c[1] + c[2] * x) * x) * x * 1e-6

    cal_temp = np.clip(p[f"INS_GYR{n}_CALTEMP"], lo, hi)
    v = raw_rad_s - poly(np.clip(temperature, lo, hi) - 35.0) + poly(cal_temp - 35.0)
    offsets = "INS_GYROFFS_" if n == 1 else f"INS_GYR{n}OFFS_"
    return v - p[offsets + axis]


@pytest.fixture(scope="module")
def causal(cubic_model, sample_train):
    return compensate(sample_train, load_model(cubic_model), "causal")[0]


def test_px4_parameters_reproduce_causal_compensation(cubic_model, causal):
    text, _ = export_model(load_model(cubic_model), "px4", ExportOptions(device_id=1310988))
    p = _px4_table(text)
    assert p["TC_G_ENABLE"] == 1 and p["TC_G0_ID"] == 1310988
    assert p["TC_G0_TREF"] == pytest.approx(0.5 * (p["TC_G0_TMIN"] + p["TC_G0_TMAX"]))
    temperature = causal["temperature"].to_numpy()
    out = px4_corrected(causal["rate"].to_numpy() / DEG, temperature, p) * DEG
    np.testing.assert_allclose(out, causal["compensated"], rtol=0, atol=1e-6)
    # beyond the range both clamp: the firmware's offset at 80 degC is its offset at TMAX
    hot = px4_corrected(0.0, np.array([80.0, p["TC_G0_TMAX"]]), p)
    assert hot[0] == hot[1]


def test_px4_single_precision_parameters_stay_within_a_micro_deg_per_s(cubic_model, causal):
    """PX4 stores REAL32: rounding every parameter to float32 moves the offset by less than 1e-6 deg/s."""
    p = {k: float(np.float32(v)) for k, v in _px4_table(export_model(load_model(cubic_model), "px4")[0]).items()}
    lo, hi = p["TC_G0_TMIN"], p["TC_G0_TMAX"]
    inside = causal[(causal["temperature"] >= lo) & (causal["temperature"] <= hi)]
    out = px4_corrected(inside["rate"].to_numpy() / DEG, inside["temperature"].to_numpy(), p) * DEG
    assert np.max(np.abs(out - inside["compensated"])) < 1e-6


def test_ardupilot_parameters_reproduce_causal_compensation(cubic_model, causal):
    text, _ = export_model(load_model(cubic_model), "ardupilot", ExportOptions(axis="y", instance=2))
    p = _parm_table(text)
    assert p["INS_TCAL2_ENABLE"] == 1
    out = ardupilot_corrected(causal["rate"].to_numpy() / DEG, causal["temperature"].to_numpy(), p, n=2, axis="Y") * DEG
    np.testing.assert_allclose(out, causal["compensated"], rtol=0, atol=1e-6)


def test_ardupilot_coefficients_are_about_35_degC_and_scaled(cubic_model):
    model = load_model(cubic_model)
    p = _parm_table(export_model(model, "ardupilot")[0])
    # the slope of the drift at 35 degC, from the model itself by a central difference
    X = np.array([[35.0 - 1e-3, 0.0], [35.0 + 1e-3, 0.0]])
    drift = model.predict(X, clamp=False)["drift"]
    slope = (drift[1] - drift[0]) / 2e-3 / DEG
    assert p["INS_TCAL1_GYR1_X"] == pytest.approx(slope * 1e6, rel=1e-6)


@pytest.mark.parametrize("fmt", ["px4", "ardupilot"])
def test_a_dT_dt_term_is_refused_naming_it(fmt, sample_train):
    from gyrocomp.config import load_config
    from gyrocomp.errors import InputError
    from gyrocomp.pipeline.train import train_direct

    model = load_model(train_direct(sample_train, load_config("polynomial"), source="polynomial", seed=0))
    with pytest.raises(InputError, match="no temperature-rate term"):
        export_model(model, fmt)
    text, summary = export_model(model, fmt, ExportOptions(fit_polynomial=True))
    added = summary["added_error_deg_h"]
    assert 0 < added["rms"] <= added["max"]


def test_fit_polynomial_is_exact_for_a_cubic_and_reports_its_error_for_a_network(cubic_model, sample_train):
    from gyrocomp.config import apply_overrides, load_config
    from gyrocomp.errors import InputError
    from gyrocomp.export.cubic import nearest_cubic
    from gyrocomp.pipeline.train import train_direct

    cubic = nearest_cubic(load_model(cubic_model))
    assert cubic.added_error_deg_h["max"] < 1e-6  # a cubic's nearest cubic is itself
    elm = load_model(train_direct(sample_train, apply_overrides(load_config("elm"), ["model.max_samples=500"]), source="elm", seed=0))
    with pytest.raises(InputError, match="elm network; the format holds only a polynomial"):
        export_model(elm, "px4")
    _, summary = export_model(elm, "px4", ExportOptions(fit_polynomial=True))
    assert summary["added_error_deg_h"]["rms"] > 0


def test_three_axis_model_exports_every_axis_to_its_firmware_axis(sample_train, tmp_path):
    """A model.json with axes gx, gy, gz: PX4 axes 0, 1, 2 and ArduPilot X, Y, Z each equal that axis' causal compensation."""
    import pandas as pd
    from typer.testing import CliRunner

    from gyrocomp.cli import app

    frame = sample_train.data
    three = pd.DataFrame({"time": frame["time"], "gx": frame["rate"], "gy": 0.01 - 0.5 * frame["rate"], "gz": 0.3 * frame["rate"], "temperature": frame["temperature"]})
    rec, model, comp = tmp_path / "three.parquet", tmp_path / "three.json", tmp_path / "comp.parquet"
    three.to_parquet(rec)
    runner = CliRunner()
    args = ["train", str(rec), "--config", "polynomial", "--set", "model.drift.rate_term=false", "--rate-col", "gx,gy,gz", "--out", str(model)]
    assert runner.invoke(app, args).exit_code == 0
    result = runner.invoke(app, ["compensate", str(rec), str(model), "--rate-col", "gx,gy,gz", "--out", str(comp)])
    assert result.exit_code == 0, result.output
    out = pd.read_parquet(comp)
    for fmt, suffix in (("px4", "params"), ("ardupilot", "parm")):
        path = tmp_path / f"three.{suffix}"
        assert runner.invoke(app, ["export", str(model), "--format", fmt, "--out", str(path), "--device-id", "3"]).exit_code == 0
        text = path.read_text()
        for index, axis in enumerate(("gx", "gy", "gz")):
            raw = out[axis].to_numpy() / DEG
            if fmt == "px4":
                got = px4_corrected(raw, out["temperature"].to_numpy(), _px4_table(text), axis=index) * DEG
            else:
                got = ardupilot_corrected(raw, out["temperature"].to_numpy(), _parm_table(text), axis="XYZ"[index]) * DEG
            np.testing.assert_allclose(got, out[f"{axis}_compensated"], rtol=0, atol=1e-6)
