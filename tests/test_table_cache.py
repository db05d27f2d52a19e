"""Sky tables' node values in the persistent cache (atmoscatter.sky._disk_memo).

A process that renders a sky another process rendered before reads the node values of its
single-scattering and multiple-scattering sky tables from the cache instead of integrating
them.  References: the stored values are the computed ones bit for bit (the cache stores
array bytes), so the results of a cold and a warm process are compared for equality, with
the integration itself disabled in the warm one (it must not run); a damaged entry is
recomputed (never read back), and every input of the values enters the key.
"""

from __future__ import annotations

import numpy as np
import pytest

import atmoscatter as ac
from atmoscatter import cache
from atmoscatter.sky import _single_table
from atmoscatter.sky import multiple as M
from atmoscatter.sky import single as S

GRID = M.MultipleScatteringGrid(6, 8, 8, 4)  # a small field: the tables are under test


def _new_process():
    """Forget everything held in memory (what a new process starts with)."""
    M._clear_process_caches()


def _views(n):
    rng = np.random.default_rng(7)
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2]) + 0.02
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _sun(elev):
    e = np.radians(elev)
    return np.array([0.3 * np.cos(e), 0.95 * np.cos(e), np.sin(e)])


def _kinds():
    return sorted(e.kind for e in cache.entries())


def test_single_scattering_table_is_read_back_bit_for_bit(cache_root, monkeypatch):
    atm = ac.earth_turbidity_atmosphere(2.5)
    v = _views(S.TABLE_THRESHOLD)
    _new_process()
    cold = ac.single_scattering(atm, v, _sun(20.0), method="table")
    assert _kinds() == ["single_scattering_table"]
    _new_process()

    def no_integration(self, v):
        raise AssertionError("the node values were integrated again")

    with monkeypatch.context() as mp:
        mp.setattr(_single_table._LogSkyTable, "_direct", no_integration, raising=False)
        # the self-check's marked cells still integrate their directions directly
        # (_LogSkyTable.J); at sun 20° in clear air there are none
        warm = ac.single_scattering(atm, v, _sun(20.0), method="table")
    np.testing.assert_array_equal(warm, cold)
    # another sun, another entry (the sun vector is in the key)
    ac.single_scattering(atm, v, _sun(21.0), method="table")
    assert _kinds() == ["single_scattering_table"] * 2


def test_multiple_scattering_table_is_read_back_bit_for_bit(cache_root, monkeypatch):
    atm = ac.earth_turbidity_atmosphere(3.0)
    v = _views(M.TABLE_THRESHOLD)
    _new_process()
    cold = ac.multiple_scattering(atm, v, _sun(10.0), grid=GRID)
    assert "multiple_scattering_table" in _kinds()
    _new_process()

    def no_march(*args, **kwargs):
        raise AssertionError("the table's node rays were marched again")

    with monkeypatch.context() as mp:
        mp.setattr(M, "_march", no_march)
        warm = ac.multiple_scattering(atm, v, _sun(10.0), grid=GRID)
    np.testing.assert_array_equal(warm, cold)
    # the field enters the key: another ground albedo is another table
    n = _kinds().count("multiple_scattering_table")
    ac.multiple_scattering(atm, v, _sun(10.0), grid=GRID, ground_albedo=0.3)
    assert _kinds().count("multiple_scattering_table") == n + 1


def test_one_table_per_sky_in_a_process(cache_root, monkeypatch):
    """A renderer calls once per batch: the batches of one sky share one table."""
    atm = ac.earth_turbidity_atmosphere(3.0)
    v = _views(M.TABLE_THRESHOLD)
    _new_process()
    built = []
    orig = M._SkyTable.__init__

    def counting(self, *a, **k):
        built.append(1)
        orig(self, *a, **k)

    monkeypatch.setattr(M._SkyTable, "__init__", counting)
    first = ac.multiple_scattering(atm, v, _sun(10.0), grid=GRID)
    second = ac.multiple_scattering(atm, v[::-1], _sun(10.0), grid=GRID)
    assert len(built) == 1
    np.testing.assert_array_equal(second, first[::-1])


def test_damaged_table_entry_is_recomputed(cache_root):
    atm = ac.earth_turbidity_atmosphere(2.5)
    v = _views(S.TABLE_THRESHOLD)
    _new_process()
    cold = ac.single_scattering(atm, v, _sun(20.0), method="table")
    (entry,) = [e for e in cache.entries() if e.kind == "single_scattering_table"]
    data = bytearray(open(entry.path, "rb").read())
    data[len(data) // 2] ^= 0xFF
    open(entry.path, "wb").write(bytes(data))
    _new_process()
    with pytest.warns(cache.CacheWarning):
        again = ac.single_scattering(atm, v, _sun(20.0), method="table")
    np.testing.assert_array_equal(again, cold)


def test_cache_off_integrates_every_time(monkeypatch):
    monkeypatch.setenv("ATMOSCATTER_CACHE_DIR", "off")
    atm = ac.earth_turbidity_atmosphere(2.5)
    calls = []
    orig = _single_table._LogSkyTable._direct

    def counting(self, v):
        calls.append(len(v))
        return orig(self, v)

    monkeypatch.setattr(_single_table._LogSkyTable, "_direct", counting)
    for _ in range(2):
        _new_process()
        ac.single_scattering(atm, _views(S.TABLE_THRESHOLD), _sun(20.0), method="table")
    assert len(calls) == 2
