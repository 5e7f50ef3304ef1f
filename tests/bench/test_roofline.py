"""The silhouette kernel's roofline: the floor from a device's rates, the rates measured, and the
table of both beside the kernel."""

import math

import pytest

from mmocap.bench import roofline
from mmocap.bench.roofline import BYTES_PER_VERTEX, FLOPS_PER_VERTEX, Rates, floor_us, measure

RATES = Rates(flops=50e9, read_bytes=40e9, clear_words=5e9, ors=0.5e9)


def test_each_need_is_the_facing_vertices_work_over_its_rate_and_the_floor_the_largest():
    us = floor_us(RATES, 20000, 640, 480)
    assert us["arithmetic"] == pytest.approx(10000 * FLOPS_PER_VERTEX / 50e9 * 1e6)
    assert us["reads"] == pytest.approx(10000 * BYTES_PER_VERTEX / 40e9 * 1e6)
    assert us["scatter"] == pytest.approx((10000 / 0.5e9 + 20 * 480 / 5e9) * 1e6)
    assert us["floor"] == max(us["arithmetic"], us["reads"], us["scatter"]) == us["scatter"]
    doubled = floor_us(RATES, 40000, 640, 480)
    assert doubled["arithmetic"] == pytest.approx(2 * us["arithmetic"])


def test_the_rates_measured_on_the_default_device_are_finite_and_positive():
    pytest.importorskip("pyopencl")
    rates, device = measure(array_bytes=64 * 1024, repeats=1)
    assert device
    for name in ("flops", "read_bytes", "clear_words", "ors"):
        value = getattr(rates, name)
        assert math.isfinite(value), name
        assert value > 0, name


def test_the_table_puts_the_kernel_beside_the_floor_with_their_ratios(monkeypatch):
    monkeypatch.setattr(roofline, "measure", lambda: (RATES, "a device"))
    table = roofline.table(20000, 100.0)
    assert table.resource.tolist()[3:] == ["floor (the largest)", "silhouette kernel (Table 2)"]
    floor = floor_us(RATES, 20000, 640, 480)["floor"]
    assert table.us_per_model_view.tolist() == pytest.approx([*floor_us(RATES, 20000, 640, 480).values(), 100.0])
    assert table.ratio_to_floor.tolist() == pytest.approx((table.us_per_model_view / floor).tolist())
    assert "10000 ORs" in table.need_per_model_view.iloc[2]  # half of 20000 vertices face the camera
