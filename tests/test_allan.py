"""gyrocomp.allan against published values and allantools.

References: NIST SP 1065 (NBS14 sets, pp. 107-108), Stable32 runs on the
allantools OCXO record, the SMAC-Group/avar ``adis_av`` maximal-overlap
Allan variance of the ADIS16405 (REFERENCES.md 2.1), and IEEE Std 952 term
definitions (REFERENCES.md 2.2).
"""

from __future__ import annotations

import csv
import dataclasses
import json

import allantools
import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from gyrocomp import allan as al
from gyrocomp.allan import deviation
from gyrocomp.allan import noise_id as noise_id_module
from gyrocomp.allan.deviation import Phase
from gyrocomp.errors import InputError, ThresholdError


def _random_rate(n, seed):
    rng = np.random.default_rng(seed)
    return 0.3 + rng.normal(size=n) + 1e-3 * np.cumsum(rng.normal(size=n))


@pytest.mark.parametrize("taus", ["octave", "all"])
def test_equals_allantools_oadev(taus):
    y = _random_rate(3001 if taus == "all" else 100_001, seed=7)
    tau, dev, n = al.oadev(y, 10.0, taus)
    ref_tau, ref_dev, _, ref_n = allantools.oadev(y, rate=10.0, data_type="freq", taus=taus)
    assert_allclose(tau, ref_tau, rtol=0)
    assert_allclose(n, ref_n, rtol=0)
    assert_allclose(dev, ref_dev, rtol=1e-10)


def test_explicit_taus_round_to_whole_m_like_allantools():
    y = _random_rate(5000, seed=3)
    taus = [0.1, 0.25, 0.26, 3.0, 1000.0]
    with pytest.warns(UserWarning, match="left out"):
        tau, dev, _ = al.oadev(y, 10.0, taus)
    ref_tau, ref_dev, _, _ = allantools.oadev(y, rate=10.0, data_type="freq", taus=np.array(taus))
    assert_allclose(tau, ref_tau[: len(tau)])
    assert_allclose(dev, ref_dev[: len(tau)], rtol=1e-10)


def test_nbs14_10_point():
    """NIST SP 1065 p. 107: OADEV 91.22945 (tau 1), 85.95287 (tau 2)."""
    _, dev, _ = al.oadev([892, 809, 823, 798, 671, 644, 883, 903, 677], 1.0, [1, 2])
    assert_allclose(dev, [91.22945, 85.95287], rtol=1e-6)


def test_nbs14_1000_point():
    """NIST SP 1065 p. 108: OADEV at tau = 1, 10, 100 of the 1000-point set."""
    n = np.empty(1001, dtype=np.int64)
    n[0] = 1234567890
    for i in range(1000):
        n[i + 1] = (16807 * n[i]) % 2147483647
    assert list(n[1:4]) == [395529916, 1209410747, 633705974]
    y = n[:1000] / 2147483647.0
    tau, dev, _ = al.oadev(y, 1.0, [1, 10, 100])
    assert_allclose(dev, [2.922319e-01, 9.159953e-02, 3.241343e-02], rtol=1e-6)


def _ocxo(real_data):
    folder = real_data("allantools-stable32-ocxo")
    f = np.loadtxt(folder / "ocxo_frequency.txt", comments="#")
    return folder, (f - 1e7) / 1e7


def test_stable32_ocxo_all_taus(real_data):
    """Stable32 OADEV of the OCXO record at every tau (5-digit print: rtol 1e-4)."""
    folder, y = _ocxo(real_data)
    ref = np.loadtxt(folder / "stable32_oadev_alltau.txt", comments="#")
    tau, dev, n = al.oadev(y, 1.0, ref[:, 1])
    assert_allclose(tau, ref[:, 1])
    assert_allclose(n, ref[:, 2])
    assert_allclose(dev, ref[:, 5], rtol=1e-4)


def test_stable32_ocxo_noise_id_and_confidence(real_data):
    """Stable32 1.60 octave run: identified alpha at every tau and 68.3 % bounds.

    The ".001" file Stable32 ran on was normalised slightly differently
    (~1e-3 in sigma, REFERENCES 2.1c), so the bounds are compared relative to
    sigma: (lo/sigma, hi/sigma) must agree to 2e-3.
    """
    folder, y = _ocxo(real_data)
    ref = np.loadtxt(folder / "oadev_octave.txt", comments="#")
    s = al.analyse(y, 1.0, taus=ref[:, 1], settings=al.AllanConfig(confidence=0.683))
    assert_allclose(s.tau_s, ref[:, 1])
    acf = len(y) // ref[:, 0] >= 30  # lag-1 ACF taus; Stable32's B1 fallback differs at m >= 2048
    assert list(s.alpha[acf]) == [int(a) for a in ref[acf, 3]]
    assert_allclose(s.adev_lo[acf] / s.adev[acf], ref[acf, 4] / ref[acf, 5], rtol=2e-3)
    assert_allclose(s.adev_hi[acf] / s.adev[acf], ref[acf, 6] / ref[acf, 5], rtol=2e-3)


@pytest.mark.parametrize("alpha", [2, 1, 0, -1, -2])
@pytest.mark.parametrize("m", [1, 3, 16, 40, 500, 4000])
def test_edf_equals_allantools_greenhall(alpha, m):
    n_phase = 10_001
    if alpha == 2 and (n_phase - 2 * m) / m <= 2:
        pytest.skip("allantools has no case 4.1")
    ref = allantools.ci.edf_greenhall(alpha=alpha, d=2, m=m, N=n_phase, overlapping=True, modified=False)
    assert_allclose(noise_id_module.edf_oadev(alpha, m, n_phase), ref, rtol=1e-9)


def test_noise_id_equals_allantools_lag1():
    y = _random_rate(20_000, seed=11)
    phase = Phase(deviation._phase(y))
    for m in (1, 2, 8, 64, 256):
        assert noise_id_module.noise_id(phase, m, 30) == allantools.ci.autocorr_noise_id(y, m, data_type="freq")[0]


def _adis(real_data, channel=0):
    folder = real_data("adis16405-static-smac")
    with np.load(folder / "adis16405_imu1.npz") as data:
        gyro = data["gyro_dps"][:, channel].copy()
        fs = float(data["fs_hz"])
    with open(folder / "adis_av_reference_imu1.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    return gyro, fs, rows


@pytest.mark.parametrize("channel", [0, 1, 2])
def test_adis16405_maximal_overlap_avar(real_data, channel):
    """SMAC-Group/avar adis_av, all 18 taus (REFERENCES 2.1e): rtol 1e-5."""
    gyro, fs, rows = _adis(real_data, channel)
    name = ["Gyro. X", "Gyro. Y", "Gyro. Z"][channel]
    ref_tau = np.array([float(r["tau_s"]) for r in rows if r["channel"] == name])
    ref_adev = np.array([float(r["adev_mo"]) for r in rows if r["channel"] == name])
    assert len(ref_tau) == 18
    tau, dev, _ = al.oadev(gyro, fs, ref_tau)
    assert_allclose(tau, ref_tau)
    assert_allclose(dev, ref_adev, rtol=1e-5)


@pytest.mark.parametrize(
    "channel, arw, bias",
    # REFERENCES 2.1e: N 2.45 / 2.58 / 2.33 deg/sqrt(h), B 38 / 46 / 44 deg/h
    [(0, 2.45, 38.0), (1, 2.58, 46.0), (2, 2.33, 44.0)],
)
def test_adis16405_readoffs(real_data, channel, arw, bias):
    gyro, fs, _ = _adis(real_data, channel)
    terms = al.analyse(gyro, fs).terms
    assert terms["arw"]["readoff"] == pytest.approx(arw, rel=0.05)
    assert terms["bias_instability"]["readoff"] == pytest.approx(bias, rel=0.05)
    assert terms["bias_instability"]["readoff_tau_s"] == pytest.approx(81.92)


def _synthetic(n, fs, arw, bias, rrw, seed):
    """White (N), flicker (B) and random-walk (K) rate noise, IEEE 952 scaling [deg/s, s].

    Flicker: one-sided PSD h/f with h = B^2/pi (IEEE's two-sided B^2/(2 pi f)),
    shaped in the frequency domain over twice the length; AVAR -> 2 ln2 B^2/pi.
    Random walk: increments K/sqrt(fs) per sample, AVAR -> K^2 tau/3.
    """
    rng = np.random.default_rng(seed)
    white = rng.normal(size=n) * arw * np.sqrt(fs)
    f = np.fft.rfftfreq(2 * n, 1.0 / fs)
    amp = np.zeros_like(f)
    amp[1:] = np.sqrt(bias**2 / np.pi / f[1:] * fs * n)
    spectrum = amp * (rng.normal(size=f.size) + 1j * rng.normal(size=f.size)) / np.sqrt(2.0)
    flicker = np.fft.irfft(spectrum, 2 * n)[:n]
    walk = np.cumsum(rng.normal(size=n)) * rrw / np.sqrt(fs)
    return white + flicker + walk


def test_recovers_synthetic_terms():
    fs, arw, bias, rrw = 10.0, 3e-3, 1e-3, 8e-5  # deg/sqrt(s), deg/s, deg/s/sqrt(s)
    terms = al.analyse(_synthetic(2**20, fs, arw, bias, rrw, seed=1), fs).terms
    assert terms["arw"]["value"] == pytest.approx(arw * 60, rel=0.10)
    assert terms["bias_instability"]["value"] == pytest.approx(bias * 3600, rel=0.10)
    assert terms["rrw"]["value"] == pytest.approx(rrw * 3600 * 60, rel=0.10)
    assert terms["arw"]["identified"] and terms["bias_instability"]["identified"] and terms["rrw"]["identified"]
    assert not terms["rate_ramp"]["identified"]
    for key in ("arw", "bias_instability", "rrw"):
        assert 0 < terms[key]["sigma"] < 0.2 * terms[key]["value"]


def test_white_noise_ci_covers_truth():
    """White rate noise: adev = sigma/sqrt(m); ~68 % of the 1-sigma intervals cover it."""
    fs, sigma = 100.0, 0.5
    s = al.analyse(np.random.default_rng(5).normal(size=2**18) * sigma, fs)
    truth = sigma / np.sqrt(s.tau_s * fs)
    covered = (s.adev_lo <= truth) & (truth <= s.adev_hi)
    assert covered.mean() >= 0.5
    assert np.all(s.alpha[:10] == 0)
    assert s.terms["arw"]["readoff"] == pytest.approx(sigma / np.sqrt(fs) * 60, rel=0.02)


def test_to_dict_contract_and_artefact():
    s = al.analyse(_random_rate(4000, seed=2), 50.0, name="run.csv")
    art = al.allan_artefact([s], inputs=[{"name": "run.csv", "sha256": "0" * 64}], settings={"taus": "octave"})
    assert art["schema"]["name"] == "gyrocomp.allan"
    entry = json.loads(json.dumps(art))["series"][0]
    for key in ("name", "column", "fs_hz", "tau_s", "adev", "adev_lo", "adev_hi", "n", "terms"):
        assert key in entry
    for key in ("quantization", "arw", "bias_instability", "rrw", "rate_ramp"):
        assert set(entry["terms"][key]) >= {"value", "unit", "sigma", "identified"}


def test_thresholds_raise_with_series_and_figure():
    s = al.analyse(np.random.default_rng(0).normal(size=20_000), 100.0, name="a.csv")
    al.check_thresholds([s], max_arw=100.0)
    with pytest.raises(ThresholdError, match="a.csv .*arw .*--max-arw 0.1"):
        al.check_thresholds([s], max_arw=0.1)


@pytest.mark.parametrize(
    "x, fs, taus, match",
    [
        ([1.0, 2.0], 1.0, "octave", "at least 3"),
        ([1.0, np.nan, 2.0, 3.0], 1.0, "octave", "NaN|nan"),
        ([1.0, 2.0, 3.0, 4.0], 0.0, "octave", "positive"),
        ([1.0, 2.0, 3.0, 4.0], 1.0, "weekly", "octave, decade, all"),
        ([1.0, 2.0, 3.0, 4.0], 1.0, [-1.0], "positive"),
    ],
)
def test_bad_input(x, fs, taus, match):
    with pytest.raises(InputError, match=match):
        al.oadev(x, fs, taus)


def test_decade_grid():
    tau, _, _ = al.oadev(np.random.default_rng(1).normal(size=2000), 1.0, "decade")
    assert list(tau) == [1, 2, 5, 10, 20, 50, 100, 200, 500]


def test_defaults_equal_shipped_toml():
    assert al.get_config() == al.AllanConfig()
    assert dataclasses.asdict(al.get_config()) == dataclasses.asdict(al.AllanConfig())


def test_plot_writes_png(tmp_path):
    s = al.analyse(np.random.default_rng(0).normal(size=20_000), 100.0, name="a")
    out = tmp_path / "allan.png"
    from gyrocomp import plots

    plots.save(plots.allan_figure([s]), out)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in tmp_path.iterdir()] == ["allan.png"]


@pytest.mark.parametrize("kind", ["csv", "parquet"])
def test_read_recording_usecols_loads_only_those_columns(tmp_path, kind):
    from gyrocomp import recordings

    t = np.arange(50) / 10.0
    frame = pd.DataFrame({"t": t, "w": np.sin(t), "temperature": 25.0 + t, "other": np.cos(t)})
    path = tmp_path / f"rec.{kind}"
    frame.to_csv(path, index=False) if kind == "csv" else frame.to_parquet(path)
    spec = recordings.ColumnSpec(time="t", rate="w")
    full = recordings.read_recording(path, spec)
    some = recordings.read_recording(path, spec, usecols=["t", "w"])
    assert list(full.data.columns) == ["time", "w", "temperature", "other"]  # an axis keeps its name
    assert list(full.axis().data.columns) == ["time", "rate", "temperature", "other"]
    assert list(some.data.columns) == ["time", "w"]
    for col in ("time", "w"):
        np.testing.assert_array_equal(some.data[col], full.data[col])
    assert (some.fs_hz, some.sha256) == (full.fs_hz, full.sha256)
    # a missing column is reported with every column the file has, as without usecols
    bad = recordings.ColumnSpec(time="t", rate="rate")
    with pytest.raises(InputError) as without:
        recordings.read_recording(path, bad)
    with pytest.raises(InputError) as with_usecols:
        recordings.read_recording(path, bad, usecols=["t", "rate"])
    assert str(with_usecols.value) == str(without.value)
    assert "'other'" in str(with_usecols.value)


@pytest.mark.parametrize("with_nulls", [False, True])
def test_parquet_recording_equals_pandas_reading(tmp_path, with_nulls):
    """The row-group-wise Parquet -> NumPy path gives what ``to_pandas`` gave: index, ints, nulls."""
    import pyarrow.parquet as pq

    from gyrocomp import recordings

    t = np.arange(40) / 4.0
    aux = np.where(t > 5, np.nan, t) if with_nulls else t**2  # NaN is stored as a null, in later row groups
    frame = pd.DataFrame({"time": t, "rate": np.arange(40), "aux": aux}, index=np.arange(40) + 7)
    path = tmp_path / "rec.parquet"
    frame.to_parquet(path, row_group_size=7)
    parquet = pq.ParquetFile(path)
    assert (recordings._parquet_arrays(parquet, parquet.schema_arrow.names) is None) == with_nulls  # which path is tested
    rec = recordings.read_recording(path)
    expected = recordings.recording_from_frame(pd.read_parquet(path), sha256=rec.sha256, name=rec.name)
    pd.testing.assert_frame_equal(rec.data, expected.data)
    assert list(rec.data.columns) == (["time", "rate"] if with_nulls else ["time", "rate", "aux"])
    np.testing.assert_array_equal(rec.column("time"), t)
    rec.data.loc[0, "rate"] = 5.0  # the recording's columns are writable
    assert rec.data["rate"].iloc[0] == 5.0
    assert rec.rate_dps[0] == 5.0  # once built, the frame is the recording's content


@pytest.mark.parametrize("temperature", [True, False])
def test_allan_on_parquet_never_imports_pandas(tmp_path, temperature):
    """`gyrocomp allan` on a Parquet recording reads and analyses it without pandas (0.35 s of import).

    Without a temperature column (no thermal test, which uses scipy.stats)
    it does not import ``scipy.special`` either (0.3-0.4 s of CPU): the
    interval's chi-square quantiles equal scipy's ``gammaincinv`` to 1e-12.
    """
    import subprocess
    import sys

    from scipy.special import gammaincinv

    t = np.arange(3000) / 10.0
    frame = pd.DataFrame({"time": t, "rate": _random_rate(len(t), 3), **({"temperature": 25.0 + 0 * t} if temperature else {})})
    frame.to_parquet(tmp_path / "rec.parquet", row_group_size=1000)  # with pandas' own metadata
    script = (
        "import runpy, sys\n"
        "sys.argv = ['gyrocomp', '--quiet', 'allan', sys.argv[1], '--out', sys.argv[2]]\n"
        "try:\n    runpy.run_module('gyrocomp', run_name='__main__')\n"
        "except SystemExit as exit:\n    assert not exit.code, exit.code\n"
        "print('PANDAS', sorted(m for m in sys.modules if m.split('.')[0] == 'pandas'))\n"
        "print('SPECIAL', 'scipy.special' in sys.modules)\n"
    )
    out = tmp_path / "allan.json"
    proc = subprocess.run([sys.executable, "-c", script, str(tmp_path / "rec.parquet"), str(out)], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[-2] == "PANDAS []"
    if not temperature:
        assert proc.stdout.splitlines()[-1] == "SPECIAL False"
    (series,) = json.loads(out.read_text())["series"]
    ref = al.analyse(frame["rate"].to_numpy(), 10.0, taus="octave")
    assert_allclose(series["adev"], ref.adev, rtol=1e-12)
    adev, edf, p = ref.adev, ref.edf, (1.0 - ref.confidence) / 2.0
    assert_allclose(series["adev_lo"], adev * np.sqrt(edf / (2.0 * gammaincinv(edf / 2.0, 1.0 - p))), rtol=1e-12)
    assert_allclose(series["adev_hi"], adev * np.sqrt(edf / (2.0 * gammaincinv(edf / 2.0, p))), rtol=1e-12)


@pytest.mark.parametrize("d", [0, 1, 2])
def test_streamed_lag1_equals_whole_array(d):
    """Noise identification streams chunks; across chunk borders it equals the plain formula."""
    rng = np.random.default_rng(5)
    y = rng.normal(size=4 * deviation._CHUNK + 12_345) + 1e-3 * np.cumsum(rng.normal(size=4 * deviation._CHUNK + 12_345))
    phase = deviation._phase(y)
    z = np.diff(phase)
    t = np.arange(len(z), dtype=float)
    z = z - np.polyval(np.polyfit(t, z, 1), t)
    z = np.diff(z, n=d)
    z = z - z.mean()
    r1 = np.dot(z[:-1], z[1:]) / np.dot(z, z)
    n = len(y)
    center = (n - 1) / 2.0
    mean = phase[-1] / n
    slope = np.dot(np.arange(n) - center, np.diff(phase)) / (n * (n * n - 1.0) / 12.0)
    assert_allclose(noise_id_module._lag1_delta(Phase(phase), 1, n, mean, slope, center, d), r1 / (1.0 + r1), rtol=1e-9)


def test_arw_readoff_only_below_the_allan_minimum():
    """Issue 18: a smoothed (denoised) recording has no -1/2 line at short tau; a far -1/2 stretch is not read as ARW.

    A 200-sample moving mean of white noise rises as tau^(+1/2) up to
    ~200 s and falls as tau^(-1/2) beyond: before the fix the read-off took
    the stretch from 512 to 16384 s and reported N = 0.59 deg/sqrt(h) at
    tau = 1 s, where the curve is far below that line (on the sample test run
    denoised by PE-LCD-ANFIS the same rule gave 19.9 against a fit of 0).
    """
    from gyrocomp.allan import analyse

    rng = np.random.default_rng(18)
    smooth = np.convolve(rng.normal(0.0, 0.01, 200_000), np.ones(200) / 200, mode="valid")
    series = analyse(smooth, 1.0)
    arw = series.terms["arw"]
    assert arw["readoff"] is None
    assert "no -0.5 slope at or below the Allan minimum" in arw["readoff_note"]
    # white noise keeps its read-off, on the short-tau line
    white = analyse(rng.normal(0.0, 0.01, 100_000), 1.0).terms["arw"]
    assert white["readoff"] == pytest.approx(0.01 * 60, rel=0.05) and white["readoff_tau_s"][0] == 1.0


@pytest.mark.parametrize("in_memory", [True, False])
def test_chunked_analysis_equals_the_whole_array(in_memory):
    """analyse_chunks (phase in memory, or spilled to a file and read back by windows) against analyse, to 1e-12.

    300 000 samples: taus up to m = 2^17, past the 2^16 chunk of the second-difference sums.
    """
    import dataclasses

    rng = np.random.default_rng(19)
    y = 0.1 + rng.normal(0.0, 0.01, 300_000) + 1e-4 * np.cumsum(rng.normal(size=300_000))
    settings = dataclasses.replace(al.AllanConfig(), max_phase_in_memory=10**9 if in_memory else 0)
    cuts = [0, 1, 70_001, 70_002, 199_999, 300_000]
    chunked = al.analyse_chunks(lambda: (y[a:b] for a, b in zip(cuts, cuts[1:])), 100.0, settings=settings)
    whole = al.analyse(y, 100.0, settings=settings)
    assert chunked.tau_s.max() > deviation._CHUNK / 100.0
    assert_allclose(chunked.adev, whole.adev, rtol=1e-12)
    assert_allclose(chunked.edf, whole.edf, rtol=1e-12)
    assert list(chunked.alpha) == list(whole.alpha)
    for key, term in whole.terms.items():
        assert chunked.terms[key]["value"] == pytest.approx(term["value"], rel=1e-9, abs=1e-15)


@pytest.mark.parametrize("slots", [64, 2])
def test_one_reading_gives_the_bits_of_two(monkeypatch, slots):
    """analyse_segment_chunks told the most samples (a Parquet file's rows) reads its pieces once, into the phase, with the same bits.

    Four segments (one of 2 samples, left out) in pieces that end at and
    between the gaps; with 2 slots for 4 segments the store runs out and
    the pieces are read twice more, as without `n_samples`.
    """
    from gyrocomp.allan import analysis

    monkeypatch.setattr(analysis, "_SEGMENT_SLOTS", slots)
    rng = np.random.default_rng(38)
    segments = [0.1 + rng.normal(0.0, 0.01, n) + 1e-4 * np.cumsum(rng.normal(size=n)) for n in (70_001, 2, 5_000, 130_000)]
    pieces = [(k, y[a:b]) for k, y in enumerate(segments) for a, b in zip([0, *range(1, len(y), 65_536)], [*range(1, len(y), 65_536), len(y)]) if b > a]
    readings = []

    def read():
        readings.append(1)
        return iter(pieces)

    two = al.analyse_segment_chunks(read, 100.0, name="x")
    readings.clear()
    one = al.analyse_segment_chunks(read, 100.0, name="x", n_samples=sum(len(y) for y in segments))
    assert len(readings) == (1 if slots == 64 else 3)  # else: the reading that ran out of room, then two
    assert [s.name for s in one] == ["x segment 1", "x segment 3", "x segment 4"]
    for a, b in zip(one, two, strict=True):
        np.testing.assert_array_equal(a.adev, b.adev)
        np.testing.assert_array_equal(a.alpha, b.alpha)
        assert a.terms == b.terms
    whole = al.analyse(segments[3], 100.0)
    assert_allclose(one[2].adev, whole.adev, rtol=1e-12)


def test_ieee952_model_reads_its_own_terms():
    """Each term alone gives its IEEE Std 952 line: N at 1 s, 0.664 B on the flat, K at 3 s ([4]_ Table C.1)."""
    from gyrocomp.allan import ieee952

    n = ieee952.from_datasheet("arw", 0.5)
    assert np.sqrt(ieee952.avar(1.0, arw=n)) * 60.0 == pytest.approx(0.5)
    b = ieee952.from_datasheet("bias_instability", 3.0)
    assert np.sqrt(ieee952.avar([10.0, 1000.0], bias_instability=b)) / b == pytest.approx([0.6643, 0.6643], abs=1e-4)
    k = ieee952.from_datasheet("rrw", 2.0)
    assert ieee952.to_datasheet("rrw", np.sqrt(ieee952.avar(3.0, rrw=k))) == pytest.approx(2.0)
