"""Tests of the on-disk cache of precomputed fields (atmoscatter.cache).

Every test points ``ATMOSCATTER_CACHE_DIR`` at its own ``tmp_path`` (fixture ``cache_root``),
so nothing reads or writes the real user cache.  References: round trips are exact by
construction (the format stores the array bytes), so they are compared for equality; the
fingerprint's format is checked against SHA-256 of the canonical text written out by hand
from the documented specification (an independent computation with :mod:`hashlib`); the
integrity checks are exercised with files damaged in the ways a crash or a disk produces
(flipped bytes, truncation, an entry under the wrong name).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import multiprocessing
import os
import subprocess
import sys
import time
import warnings
import zipfile

import numpy as np
import pytest

import atmoscatter as ac
from atmoscatter import cache
from atmoscatter.cache import CacheWarning
from atmoscatter.cli import main


def _arrays(seed=0):
    rng = np.random.default_rng(seed)
    return {
        "field": rng.random((4, 3, 5, 2, 3)),
        "nodes": rng.random(7).astype(np.float32),
        "orders": np.arange(6, dtype=np.int32),
        "ground": rng.random(5) > 0.5,
        "albedo": np.array(0.3),
        "strided": rng.random((6, 6))[::2, 1::2],
    }


def _mp_context():
    # fork starts a worker in milliseconds (spawn would re-import the package, ~1 s each)
    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("fork" if "fork" in methods else "spawn")


# ---------------------------------------------------------------------------------------
# round trip and listing
# ---------------------------------------------------------------------------------------
def test_round_trip(cache_root):
    a = _arrays()
    key = cache.fingerprint("test", 1)
    assert cache.load("field", key) is None
    path = cache.store("field", key, a, meta={"atmosphere": "earth", "wavelengths": (680.0, 550.0)})
    assert path == str(cache_root / "field" / f"{key}.v{cache.FORMAT_VERSION}.npz")
    b = cache.load("field", key)
    assert set(b) == set(a)
    for name in a:
        assert b[name].dtype == a[name].dtype and b[name].shape == a[name].shape
        np.testing.assert_array_equal(b[name], a[name])  # exact: the bytes are stored
    b["field"][...] = -1.0  # a fresh copy: the next load is unaffected
    np.testing.assert_array_equal(cache.load("field", key)["field"], a["field"])
    (e,) = cache.entries()
    assert (e.kind, e.key, e.path) == ("field", key, path)
    assert e.size == os.path.getsize(path)
    assert e.meta == {"atmosphere": "earth", "wavelengths": [680.0, 550.0]}
    assert cache.entries("other") == []
    # no temporary file is left behind
    assert sorted(os.listdir(cache_root / "field")) == [os.path.basename(path)]


def test_file_is_plain_npz_without_pickle(cache_root):
    key = cache.fingerprint("plain")
    path = cache.store("field", key, {"x": np.arange(3.0)})
    with np.load(path, allow_pickle=False) as z:  # readable by NumPy alone
        assert set(z.files) == {"x", "__header__", "__sha256__"}
        header = json.loads(z["__header__"].item())
    assert header["kind"] == "field" and header["key"] == key
    assert header["version"] == cache.FORMAT_VERSION


def test_bad_arguments(cache_root):
    with pytest.raises(ValueError, match="kind"):
        cache.store("a/b", "abc", {"x": np.zeros(1)})
    with pytest.raises(ValueError, match="key"):
        cache.load("field", "../etc")
    with pytest.raises(ValueError, match="array names"):
        cache.store("field", "abc", {"__header__": np.zeros(1)})
    with pytest.raises(TypeError, match="object"):
        cache.store("field", "abc", {"x": np.array([None, 1], dtype=object)})
    with pytest.raises(TypeError, match="meta"):
        cache.store("field", "abc", {"x": np.zeros(1)}, meta={"f": object()})
    with pytest.raises(TypeError, match="non-empty dict"):
        cache.store("field", "abc", {})


# ---------------------------------------------------------------------------------------
# fingerprint
# ---------------------------------------------------------------------------------------
def test_fingerprint_matches_documented_format():
    """SHA-256 of the canonical text written by hand from the module docstring."""
    text = ('["atmoscatter-fingerprint",1,[{"albedo":"f:0x1.3333333333333p-2","n_mu":"i:16",'
            '"name":"s:earth"},["f:0x1.8000000000000p+0","i:2",null,true],"i:8000"]]')
    expected = hashlib.sha256(text.encode()).hexdigest()
    assert cache.fingerprint({"name": "earth", "n_mu": 16, "albedo": 0.3},
                             (1.5, 2, None, True), 8000.0) == expected


def test_fingerprint_of_a_dataclass_and_array_matches_documented_format():
    @dataclasses.dataclass(frozen=True)
    class Grid:
        n: int = 3
        step: float = 0.1

    a = np.array([[1.0, 2.5]], dtype=np.float32)
    digest = hashlib.sha256(np.array([[1.0, 2.5]], dtype="<f8").tobytes()).hexdigest()
    q = f"{Grid.__module__}.{Grid.__qualname__}"
    text = ('["atmoscatter-fingerprint",1,[{"dataclass":"' + q + '","fields":{"n":"i:3",'
            '"step":"f:0x1.999999999999ap-4"}},{"dtype":"<f8","ndarray":[1,2],"sha256":"'
            + digest + '"}]]')
    assert cache.fingerprint(Grid(), a) == hashlib.sha256(text.encode()).hexdigest()


_SUBPROCESS = """
import atmoscatter as ac
from atmoscatter.cache import fingerprint
print(fingerprint("multiple_scattering", ac.earth_atmosphere(), ac.mars_atmosphere(),
                  ac.MULTIPLE_SCATTERING_GRID, 0.3))
"""


def test_fingerprint_is_the_same_in_another_process():
    here = cache.fingerprint("multiple_scattering", ac.earth_atmosphere(), ac.mars_atmosphere(),
                             ac.MULTIPLE_SCATTERING_GRID, 0.3)
    env = dict(os.environ, PYTHONHASHSEED="12345")  # str hashes differ from this process
    out = subprocess.run([sys.executable, "-c", _SUBPROCESS], capture_output=True, text=True,
                         env=env, check=True, timeout=120)
    assert out.stdout.strip() == here


def test_fingerprint_survives_a_file_round_trip():
    # the same physical atmosphere read back from its JSON form gives the same key
    atm = ac.earth_atmosphere(wavelengths=[700.0, 546.1, 435.8])
    again = ac.atmosphere_from_dict(json.loads(json.dumps(ac.atmosphere_to_dict(atm))))
    assert again is not atm
    assert cache.fingerprint(again) == cache.fingerprint(atm)
    # the name is a label, not physics
    assert cache.fingerprint(dataclasses.replace(atm, name="renamed")) == cache.fingerprint(atm)


def _variants(atm):
    """Atmospheres that differ from ``atm`` in exactly one thing (one ulp for numbers)."""
    up = lambda x: float(np.nextafter(x, np.inf))  # noqa: E731
    out = {}
    for i, c in enumerate(atm.constituents):
        def repl(i=i, c=c, **kw):
            cons = list(atm.constituents)
            cons[i] = dataclasses.replace(c, **kw)
            return dataclasses.replace(atm, constituents=tuple(cons))
        for j in range(atm.n_wavelengths):
            sca = list(c.scattering)
            sca[j] = up(sca[j])
            out[f"{c.name}.scattering[{j}]"] = repl(scattering=sca)
            ab = list(c.absorption)
            ab[j] = up(ab[j])
            out[f"{c.name}.absorption[{j}]"] = repl(absorption=ab)
        p = c.profile
        for f in dataclasses.fields(p):
            v = getattr(p, f.name)
            v = (up(v[0]),) + tuple(v[1:]) if isinstance(v, tuple) else up(v)
            out[f"{c.name}.profile.{f.name}"] = repl(profile=dataclasses.replace(p, **{f.name: v}))
        if isinstance(c.phase, ac.HenyeyGreensteinPhase | ac.CornetteShanksPhase):
            out[f"{c.name}.phase.g"] = repl(phase=dataclasses.replace(c.phase, g=up(c.phase.g)))
            out[f"{c.name}.phase type"] = repl(
                phase=(ac.CornetteShanksPhase if isinstance(c.phase, ac.HenyeyGreensteinPhase)
                       else ac.HenyeyGreensteinPhase)(g=c.phase.g))
        else:
            out[f"{c.name}.phase type"] = repl(
                phase=ac.IsotropicPhase() if isinstance(c.phase, ac.RayleighPhase) else ac.RayleighPhase())
        out[f"{c.name}.name"] = repl(name=c.name + "_")
        out[f"without {c.name}"] = atm.without(c.name)
    for j in range(atm.n_wavelengths):
        wl = list(atm.wavelengths)
        wl[j] = up(wl[j])
        out[f"wavelengths[{j}]"] = dataclasses.replace(atm, wavelengths=wl)
    out["planet_radius"] = dataclasses.replace(atm, planet_radius=up(atm.planet_radius))
    out["top_radius"] = dataclasses.replace(atm, top_radius=up(atm.top_radius))
    out["constituent order"] = dataclasses.replace(atm, constituents=atm.constituents[::-1])
    return out


@pytest.mark.parametrize("preset", ["earth", "keller_bohn"])
def test_fingerprint_changes_with_every_physical_field(preset):
    atm = {"earth": ac.earth_atmosphere, "keller_bohn": ac.keller_bohn_atmosphere}[preset]()
    variants = _variants(atm)
    assert len(variants) > 20
    base = cache.fingerprint(atm)
    keys = {name: cache.fingerprint(v) for name, v in variants.items()}
    same = [name for name, k in keys.items() if k == base]
    assert not same, f"fingerprint did not change for {same}"
    assert len(set(keys.values())) == len(keys)  # and no two variants collide


def test_tabulated_profile_nodes_enter_the_fingerprint():
    p = ac.TabulatedProfile(altitudes=(0.0, 1e4, 2e4), densities=(1.0, 0.3, 0.05))
    c = ac.Constituent(name="air", scattering=[1e-5], profile=p)
    atm = ac.Atmosphere(planet_radius=6.36e6, top_radius=6.42e6, wavelengths=[550.0],
                        constituents=[c])
    p2 = ac.TabulatedProfile(altitudes=(0.0, 1e4, 2e4), densities=(1.0, 0.3, 0.0500001))
    atm2 = dataclasses.replace(atm, constituents=(dataclasses.replace(c, profile=p2),))
    assert cache.fingerprint(atm) != cache.fingerprint(atm2)


def test_fingerprint_plain_values():
    grid = ac.MULTIPLE_SCATTERING_GRID
    base = cache.fingerprint(grid, 0.3)
    assert cache.fingerprint(dataclasses.replace(grid, n_mu=grid.n_mu + 2), 0.3) != base
    assert cache.fingerprint(grid, float(np.nextafter(0.3, 1.0))) != base
    assert cache.fingerprint(grid, np.float64(0.3)) == base  # NumPy scalars are their value
    assert cache.fingerprint(0) == cache.fingerprint(0.0)  # equal numbers, equal keys
    assert cache.fingerprint(True) != cache.fingerprint(1)
    assert cache.fingerprint("1") != cache.fingerprint(1)
    assert cache.fingerprint((1, 2)) == cache.fingerprint([1, 2])
    assert cache.fingerprint((1, 2)) != cache.fingerprint((2, 1))
    assert cache.fingerprint({"a": 1, "b": 2}) == cache.fingerprint({"b": 2, "a": 1})
    assert cache.fingerprint(float("nan")) != cache.fingerprint(float("inf"))
    assert cache.fingerprint(np.arange(4.0)) != cache.fingerprint(np.arange(4.0).reshape(2, 2))
    assert cache.fingerprint(np.arange(4.0)) == cache.fingerprint(np.arange(4.0, dtype=np.float32))
    with pytest.raises(TypeError, match=r"parts\[1\]\['x'\] of type object"):
        cache.fingerprint(1, {"x": object()})
    with pytest.raises(TypeError, match="dict keys"):
        cache.fingerprint({1: 2})


# ---------------------------------------------------------------------------------------
# integrity
# ---------------------------------------------------------------------------------------
def _damage_flip(path, where):
    data = bytearray(open(path, "rb").read())
    i = {"data": len(data) // 2, "header": 200, "end": len(data) - 10}[where]
    data[i] ^= 0xFF
    open(path, "wb").write(bytes(data))


def _damage_truncate(path, fraction):
    data = open(path, "rb").read()
    open(path, "wb").write(data[: int(len(data) * fraction)])


def _damage_rewrite_array(path):
    """A valid zip whose array no longer matches the checksum (zip CRCs are recomputed)."""
    with np.load(path, allow_pickle=False) as z:
        members = {n: z[n] for n in z.files}
    members["field"] = members["field"].copy()
    members["field"].flat[3] += 1e-12
    with zipfile.ZipFile(path, "w") as zf:
        for n, a in members.items():
            with zf.open(n + ".npy", "w") as f:
                np.lib.format.write_array(f, a, allow_pickle=False)


@pytest.mark.parametrize("damage", [
    lambda p: _damage_flip(p, "data"),
    lambda p: _damage_flip(p, "header"),
    lambda p: _damage_flip(p, "end"),
    lambda p: _damage_truncate(p, 0.5),
    lambda p: _damage_truncate(p, 0.999),
    lambda p: _damage_truncate(p, 0.0),
    _damage_rewrite_array,
], ids=["flip-data", "flip-header", "flip-directory", "truncate-half", "truncate-end",
        "empty", "checksum"])
def test_corrupt_entry_is_never_returned(cache_root, damage):
    key = cache.fingerprint("corrupt")
    path = cache.store("field", key, _arrays())
    damage(path)
    with pytest.warns(CacheWarning, match="corrupt entry"):
        assert cache.load("field", key) is None
    assert not os.path.exists(path)  # deleted, so it is recomputed
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert cache.load("field", key) is None  # warned once only
    assert cache.store("field", key, _arrays()) == path  # refilled normally
    np.testing.assert_array_equal(cache.load("field", key)["field"], _arrays()["field"])


def test_entry_under_the_wrong_name_is_rejected(cache_root):
    k1, k2 = cache.fingerprint(1), cache.fingerprint(2)
    p1 = cache.store("field", k1, _arrays(1))
    p2 = os.path.join(os.path.dirname(p1), f"{k2}.v{cache.FORMAT_VERSION}.npz")
    os.replace(p1, p2)
    with pytest.warns(CacheWarning, match="does not match"):
        assert cache.load("field", k2) is None


# ---------------------------------------------------------------------------------------
# settings: location, off, unwritable, size cap
# ---------------------------------------------------------------------------------------
def test_default_location_is_the_platform_user_cache(monkeypatch):
    import platformdirs

    monkeypatch.delenv("ATMOSCATTER_CACHE_DIR", raising=False)
    assert cache.cache_dir() == os.path.abspath(platformdirs.user_cache_dir("atmoscatter"))


def test_off_disables_the_cache(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("ATMOSCATTER_CACHE_DIR", "off")
    assert cache.cache_dir() is None
    assert cache.store("field", "abc", {"x": np.ones(2)}) is None
    assert cache.load("field", "abc") is None
    assert cache.entries() == [] and cache.clear() == 0
    calls = []
    for _ in range(2):
        cache.cached("field", "abc", lambda: calls.append(1) or {"x": np.ones(2)})
    assert len(calls) == 2
    assert os.listdir(tmp_path) == []  # nothing written (not even a directory "off")


def test_unwritable_directory_falls_back_to_memory(tmp_path, monkeypatch):
    # a path below a regular file cannot be created, even by root (chmod would not stop root)
    (tmp_path / "file").write_text("not a directory")
    root = tmp_path / "file" / "sub"
    monkeypatch.setenv("ATMOSCATTER_CACHE_DIR", str(root))
    a = _arrays()
    with pytest.warns(CacheWarning, match=str(root)) as record:
        assert cache.store("field", "abc", a) is None
    assert len(record) == 1
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # one warning per directory and process
        np.testing.assert_array_equal(cache.load("field", "abc")["field"], a["field"])
        cache.store("field", "def", a)
        with cache.lock("field", "abc") as held:
            assert held is False
        calls = []
        for _ in range(2):
            cache.cached("field", "ghi", lambda: calls.append(1) or {"x": np.ones(2)})
        assert len(calls) == 1  # the memory fallback still avoids the recomputation
        assert cache.entries() == []


def test_size_cap_evicts_least_recently_used(cache_root, monkeypatch):
    keys = [cache.fingerprint("lru", i) for i in range(4)]
    size = os.path.getsize(cache.store("field", keys[0], _arrays(0)))
    monkeypatch.setenv("ATMOSCATTER_CACHE_MAX_BYTES", str(int(3.5 * size)))
    cache.store("field", keys[1], _arrays(1))
    cache.store("other", keys[2], _arrays(2))  # the cap covers every kind
    t0 = time.time() - 1000
    for i, k in enumerate(keys[:3]):  # distinct, past use times: 0 oldest, 2 newest
        kind = "other" if i == 2 else "field"
        os.utime(cache_root / kind / f"{k}.v{cache.FORMAT_VERSION}.npz", (t0 + i, t0 + i))
    assert cache.load("field", keys[0]) is not None  # a hit makes 0 the most recent
    cache.store("field", keys[3], _arrays(3))  # 4 entries > 3.5: the LRU one (1) goes
    assert {e.key for e in cache.entries()} == {keys[0], keys[2], keys[3]}
    assert cache.load("field", keys[1]) is None
    assert sum(e.size for e in cache.entries()) <= 3.5 * size


def test_entry_larger_than_the_cap_is_not_stored(cache_root, monkeypatch):
    monkeypatch.setenv("ATMOSCATTER_CACHE_MAX_BYTES", "1K")
    assert cache.max_bytes() == 1024
    with pytest.warns(CacheWarning, match="exceeds"):
        assert cache.store("field", "big", {"x": np.zeros(1000)}) is None
    assert cache.store("field", "small", {"x": np.zeros(4)}) is not None


@pytest.mark.parametrize("text,expected", [("123", 123), ("2G", 2 * 1024**3),
                                           ("1.5GiB", 3 * 1024**3 // 2), ("500 MB", 500 * 1024**2)])
def test_max_bytes_setting(monkeypatch, text, expected):
    monkeypatch.setenv("ATMOSCATTER_CACHE_MAX_BYTES", text)
    assert cache.max_bytes() == expected


def test_bad_max_bytes_warns_and_uses_default(monkeypatch):
    monkeypatch.setenv("ATMOSCATTER_CACHE_MAX_BYTES", "lots")
    with pytest.warns(CacheWarning, match="ATMOSCATTER_CACHE_MAX_BYTES"):
        assert cache.max_bytes() == cache.DEFAULT_MAX_BYTES


# ---------------------------------------------------------------------------------------
# concurrency
# ---------------------------------------------------------------------------------------
def _writer_reader(args):
    """Store this worker's field and read the entry back, many times; check every read."""
    root, wid, rounds = args
    os.environ["ATMOSCATTER_CACHE_DIR"] = root
    warnings.simplefilter("error", CacheWarning)  # a corrupt read would raise here
    big = np.full((64, 64, 32), float(wid))  # 1 MiB: writes take a while
    seen = set()
    for _ in range(rounds):
        cache.store("field", "shared", {"field": big, "wid": np.array(wid)}, meta={"wid": wid})
        d = cache.load("field", "shared")
        if d is None:
            return f"worker {wid}: miss after a store"
        w = int(d["wid"])
        if not np.all(d["field"] == w):  # a mix of two writers would show here
            return f"worker {wid}: inconsistent entry"
        seen.add(w)
    return sorted(seen)


def test_concurrent_writers_never_expose_a_partial_entry(cache_root):
    n = 4
    with _mp_context().Pool(n) as pool:
        results = pool.map(_writer_reader, [(str(cache_root), w, 25) for w in range(n)])
    for r in results:
        assert isinstance(r, list), r
    (e,) = cache.entries()
    assert e.meta["wid"] in range(n)
    assert [f for f in os.listdir(cache_root / "field") if f.endswith(".tmp")] == []


def _compute_once(args):
    root, counter = args
    os.environ["ATMOSCATTER_CACHE_DIR"] = root

    def compute():
        with open(counter, "a") as fh:
            fh.write("x\n")
        time.sleep(0.5)
        return {"x": np.arange(10.0)}

    return cache.cached("field", "once", compute, timeout=60)["x"].tolist()


def test_lock_avoids_duplicate_work(cache_root, tmp_path):
    counter = tmp_path / "calls.txt"
    with _mp_context().Pool(3) as pool:
        results = pool.map(_compute_once, [(str(cache_root), str(counter))] * 3)
    assert results == [list(range(10))] * 3
    assert counter.read_text().count("x") == 1


def test_lock_times_out_instead_of_deadlocking(cache_root):
    with cache.lock("field", "k") as held:
        assert held
        t0 = time.monotonic()
        with cache.lock("field", "k", timeout=0.3) as second:
            assert second is False
        assert 0.25 < time.monotonic() - t0 < 10
    with cache.lock("field", "k", timeout=0) as again:  # released on exit
        assert again


def _lock_path(root, key):
    return root / "field" / f"{key}.v{cache.FORMAT_VERSION}.lock"


def test_stale_locks_are_broken(cache_root):
    (cache_root / "field").mkdir(parents=True)
    # held by a process that has exited (same host)
    p = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                       capture_output=True, text=True, check=True)
    import socket

    _lock_path(cache_root, "dead").write_text(json.dumps(
        {"host": socket.gethostname(), "pid": int(p.stdout), "token": "t"}))
    with cache.lock("field", "dead", timeout=5) as held:
        assert held
    # too old (e.g. a host that crashed)
    lp = _lock_path(cache_root, "old")
    lp.write_text(json.dumps({"host": "elsewhere", "pid": 1, "token": "t"}))
    os.utime(lp, (time.time() - 7200, time.time() - 7200))
    with cache.lock("field", "old", timeout=5) as held:
        assert held
    assert not lp.exists()


# ---------------------------------------------------------------------------------------
# command line
# ---------------------------------------------------------------------------------------
def test_cli_dir_list_clear(cache_root, capsys):
    atm = ac.earth_atmosphere()
    key = cache.fingerprint(atm)
    cache.store("multiple_scattering", key, _arrays(),
                meta={"atmosphere": atm.name, "wavelengths": atm.wavelengths})
    cache.store("table", "abc", {"x": np.zeros(3)})

    assert main(["cache", "dir"]) == 0
    assert capsys.readouterr().out.strip() == str(cache_root)

    assert main(["cache", "list"]) == 0
    out = capsys.readouterr().out
    assert key[:12] in out and "atmosphere=earth" in out and "wavelengths=680,550,440" in out
    assert "2 entries" in out

    assert main(["cache", "list", "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    assert {(d["kind"], d["key"]) for d in listed} == {("multiple_scattering", key), ("table", "abc")}

    assert main(["cache", "clear", "--kind", "table"]) == 0
    assert "removed 1 entry" in capsys.readouterr().out
    assert [e.kind for e in cache.entries()] == ["multiple_scattering"]
    assert main(["cache", "clear"]) == 0
    capsys.readouterr()
    assert cache.entries() == []


def test_cli_errors_are_one_line(cache_root, capsys, monkeypatch):
    assert main(["cache", "list", "--kind", "no/such"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("atmoscatter: error: kind") and "\n" not in err
    monkeypatch.setenv("ATMOSCATTER_CACHE_DIR", "off")
    assert main(["cache", "dir"]) == 1
    captured = capsys.readouterr()
    assert captured.out == "" and "off" in captured.err


def test_docstring_examples():
    import doctest
    import importlib
    import pkgutil

    # the examples live in the modules of the atmoscatter.cache package
    modules = [importlib.import_module(f"{cache.__name__}.{m.name}")
               for m in pkgutil.iter_modules(cache.__path__)]
    results = [doctest.testmod(m, optionflags=doctest.ELLIPSIS, verbose=False) for m in modules]
    assert sum(r.attempted for r in results) >= 3 and sum(r.failed for r in results) == 0
