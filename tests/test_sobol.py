"""The screening's and the starts' Sobol samples: scipy's to the bit, kept in the user's cache
so that a later process reads them without importing scipy.stats."""
import io
import os
import subprocess
import sys

import numpy as np
import pytest
from scipy.stats import qmc

from optdesign.numerics import sobol
from tests.conftest import ROOT, kept_files


def _kept(where):
    return kept_files(where, "sobol-")


@pytest.mark.parametrize("d, n, seed", [(1, 512, 0), (4, 512, 0), (5, 4096, 3), (3, 300, 7)])
def test_the_sample_is_scipys_to_the_bit_drawn_or_kept(own_cache, d, n, seed):
    m = max(1, int(np.ceil(np.log2(n))))
    theirs = qmc.Sobol(d=d, scramble=True, seed=seed).random_base2(m)[:n]
    drawn = sobol.unit_sample(d, n, seed)
    kept = sobol.unit_sample(d, n, seed)                 # read back from the cache
    assert np.array_equal(drawn, theirs) and np.array_equal(kept, theirs)
    assert len(_kept(own_cache)) == 1
    if n & (n - 1) == 0:        # the starts draw random(512) where the screening draws
        #                             random_base2(9): the same points
        assert np.array_equal(qmc.Sobol(d=d, scramble=True, seed=seed).random(n), theirs)


def test_scale_is_qmc_scale_to_the_bit():
    rng = np.random.default_rng(1)
    unit = rng.uniform(size=(200, 4))
    lower, upper = np.array([100, 20.5, 1e-3, 30]), np.array([400, 60.25, 1e3, 31])
    assert np.array_equal(sobol.scale(unit, lower, upper), qmc.scale(unit, lower, upper))


def test_a_later_process_reads_the_kept_sample_without_scipy_stats(own_cache):
    first = sobol.unit_sample(4, 512, 0)
    code = ("import sys, numpy as np; from optdesign.numerics import sobol; "
            "s = sobol.unit_sample(4, 512, 0); np.save(sys.stdout.buffer, s); "
            "assert 'scipy.stats' not in sys.modules, 'scipy.stats imported'")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, cwd=ROOT,
                         env=dict(os.environ), check=True).stdout
    assert np.array_equal(np.load(io.BytesIO(out)), first)


@pytest.mark.parametrize("spoil", ["garbage", "cut short", "another sample's",
                                   "writable by others"])
def test_a_kept_sample_not_to_be_trusted_is_ignored_and_made_anew(own_cache, spoil):
    made = sobol.unit_sample(3, 512, 0)
    (path,) = _kept(own_cache)
    good = path.read_bytes()
    if spoil == "garbage":
        path.write_bytes(b"\x93NUMPY" + b"\0" * 300)
    elif spoil == "cut short":
        path.write_bytes(good[:len(good) // 2])
    elif spoil == "another sample's":
        sobol.unit_sample(3, 512, 1)
        foreign = next(p for p in _kept(own_cache) if p != path)
        path.write_bytes(foreign.read_bytes())
    else:
        path.chmod(0o666)
    assert np.array_equal(sobol.unit_sample(3, 512, 0), made)
    assert path.read_bytes() == good and path.stat().st_mode & 0o077 == 0   # made anew


def test_nothing_is_kept_when_the_cache_is_off(own_cache, monkeypatch):
    monkeypatch.setenv("OPTDESIGN_COMPILE", "off")
    m = sobol.unit_sample(2, 512, 0)
    assert np.array_equal(m, qmc.Sobol(d=2, scramble=True, seed=0).random_base2(9))
    assert not own_cache.exists() or not _kept(own_cache)
