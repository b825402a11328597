"""LCD block by block with its components on disk (issue 38, training memory): the whole record's decomposition, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from gyrocomp.decompose.lcd import lcd
from gyrocomp.decompose.lcd_blocks import RowFile, lcd_on_disk


def _on_disk(x, tmp_path, **kw):
    store, count = lcd_on_disk(x, tmp_path, **kw)
    try:
        return np.array([store.read(k, 0, x.size) for k in range(count)])
    finally:
        store.close()


def _signal(n, seed):
    rng = np.random.default_rng(seed)
    t = np.arange(n)
    return np.sin(2 * np.pi * t / 5000) + 0.3 * np.sin(2 * np.pi * t / 300) + 0.05 * rng.standard_normal(n)


@pytest.mark.parametrize("block", [20_000, 4096, 777])
def test_blocks_give_the_whole_records_components_bit_for_bit(tmp_path, block):
    """The noise ISCs have ~13 000 knots, so blocks of 777 and 4096 samples solve their
    baseline splines in windows of 64 knots either side, the slow ones whole."""
    x = _signal(20_000, 1)
    whole = lcd(x)
    got = _on_disk(x, tmp_path, block=block)
    assert got.shape == whole.shape == (11, x.size)
    np.testing.assert_array_equal(got, whole)


@pytest.mark.parametrize("block", [4096, 333])
def test_plateaus_across_block_edges_are_the_whole_records_extrema(tmp_path, block):
    """A quantised signal has runs of equal samples (an extremum at a plateau's middle):
    a block's window grows until every run through its ends lies inside it."""
    x = np.round(_signal(20_000, 2) * 20) / 20
    x[5000:5400] = x[5000]  # one plateau longer than a block of 333 and its margins
    np.testing.assert_array_equal(_on_disk(x, tmp_path, block=block), lcd(x))


def test_few_components_and_settings_as_the_whole_record(tmp_path):
    x = _signal(9000, 3)
    kw = dict(q=0.3, sd_stop=0.1, max_components=3, max_sift=4)
    np.testing.assert_array_equal(_on_disk(x, tmp_path, block=1000, **kw), lcd(x, **kw))


def test_a_short_window_end_is_what_the_overlap_hides(tmp_path):
    """With no knots of overlap the artificial spline ends show (the test of the overlap itself)."""
    x = _signal(20_000, 4)
    assert not np.array_equal(_on_disk(x, tmp_path, block=1000, overlap=0), lcd(x))


def test_row_file_reads_what_was_written(tmp_path):
    store = RowFile(tmp_path / "rows.f8", 2, 10)
    store.write(1, 3, np.arange(5.0))
    np.testing.assert_array_equal(store.read(1, 0, 10), [0, 0, 0, 0, 1, 2, 3, 4, 0, 0])
    np.testing.assert_array_equal(store.read(0, 0, 10), np.zeros(10))
    store.close()
