"""The scrambled Sobol samples of the screening and the starts, kept in the user's cache.

A solve screens its box on scipy's scrambled Sobol sequence (``scipy.stats.qmc.Sobol``, Owen
scrambling seeded by ``solver.seed``). Importing ``scipy.stats`` costs a command about half a
second, and scipy's first engine of a process reads the direction numbers of 21201
dimensions (a few tens of milliseconds); yet the sample depends only on the dimension, the
number of points, the seed and scipy's version. So the unit sample is kept in the user's cache
folder (:mod:`optdesign.numerics.user_cache`, trusted on its terms: the user's own file, not
writable by others, its trailer naming the digest of what it was drawn from and the checksum
of its bytes), and a later process reads it: the same numbers to the bit, without importing
``scipy.stats``. Under ``OPTDESIGN_COMPILE=off``, or where the user has no cache folder, it is
drawn with scipy every time.
"""
from __future__ import annotations

import hashlib
import io
import math

import numpy as np

from optdesign.numerics import user_cache

#: a kept sample's trailer tag (:func:`optdesign.numerics.user_cache.trailer`)
CACHE_TAG = "optdesign-sobol"
#: the layout of a kept file (part of its digest)
FORMAT = 1


def unit_sample(d: int, n: int, seed: int) -> np.ndarray:
    """The first ``n`` points of scipy's scrambled Sobol sequence in ``d`` dimensions, seeded
    by ``seed``: ``qmc.Sobol(d, scramble=True, seed=seed).random_base2(m)[:n]``, 2**m the
    least power of two of at least ``n`` (and 2), an (n, d) array in the unit cube."""
    where, digest = _cache_of(d, n, seed)
    kept = _cached(where, digest)
    if kept is not None and kept.shape == (n, d):
        return kept
    from scipy.stats import qmc

    m = max(1, int(math.ceil(math.log2(max(n, 2)))))
    out = qmc.Sobol(d=d, scramble=True, seed=seed).random_base2(m)[:n]
    if where is not None:
        _keep(where, digest, out)
    return out


def scale(unit: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Points of the unit cube onto the box [lower, upper]: ``qmc.scale``'s arithmetic,
    ``unit * (upper - lower) + lower``, the same values to the bit."""
    lower, upper = np.asarray(lower, dtype=float), np.asarray(upper, dtype=float)
    return np.asarray(unit) * (upper - lower) + lower


def _cache_of(d: int, n: int, seed: int):
    """(the cache folder or None, the digest of the sample's recipe)."""
    where = user_cache.in_use()
    if where is None:
        return None, ""
    import scipy        # the package's version alone: scipy.stats is not imported

    recipe = f"{FORMAT} sobol scrambled d={d} n={n} seed={int(seed)} scipy={scipy.__version__}"
    return where, hashlib.sha256(recipe.encode()).hexdigest()


def _name(digest: str) -> str:
    return f"sobol-{digest[:40]}.npy"


def _cached(where, digest: str) -> np.ndarray | None:
    body = user_cache.kept(where, _name(digest), CACHE_TAG, digest)
    if body is None:
        return None
    try:
        out = np.load(io.BytesIO(body), allow_pickle=False)
    except (ValueError, OSError, EOFError):
        return None
    return out if out.dtype == np.float64 and out.ndim == 2 else None


def _keep(where, digest: str, sample: np.ndarray) -> None:
    """``sample`` into the cache (a failure costs the next process the draw alone)."""
    buffer = io.BytesIO()
    np.save(buffer, np.ascontiguousarray(sample, dtype=np.float64), allow_pickle=False)
    user_cache.keep(where / _name(digest), CACHE_TAG, digest, buffer.getvalue())
