"""Skin colour models: the Jones–Rehg Gaussian mixtures and a trainable histogram.

The paper extracts the hand silhouette "via a learned skin colour model" (section 6,
reference [7]: M. J. Jones and J. M. Rehg, "Statistical color models with application to
skin detection", IJCV 46(1):81–96, 2002).  A pixel of colour ``c`` is labelled skin by the
likelihood-ratio test of Jones & Rehg (their eq. 2)::

    P(c | skin) / P(c | non-skin) >= Θ

where the class-conditional densities are either

- the published 16-component mixtures of diagonal Gaussians in RGB (`SkinModel`), read
  from the package data file ``jones-rehg-skin-gmm.csv``, or
- normalised colour histograms counted from labelled images (`HistogramSkinModel`,
  Jones & Rehg's histogram variant).

Speed: an image is never evaluated pixel by pixel.  Both models classify through a
colour lookup table over a regular grid of ``bins`` levels per channel (``bins**3``
cells): each 8-bit channel is shifted right to its bin index and the three indices are
packed into one integer that addresses the table.  For the mixture model the table
holds the log likelihood ratio at the bin centres, built once on first use and cached.
With the default 64 bins per channel a bin is 4 grey levels wide, so a colour is at most
1.5 levels per channel from the centre that stands for it.  Measured over 2 M uniformly
random colours, the tabulated log ratio then differs from the exact one by 0.21 (median),
1.2 (99th percentile) and 3.5 at most (near white, where a non-skin component with a
standard deviation of 1.7 levels is narrower than a bin); the skin / non-skin decision
at Θ = 0.5 differs from the exact one for 0.6 % of colours and 0.8 % of the pixels of
the example video, all of them close to the decision boundary.  ``bins=128`` halves
these figures; ``bins=256`` is exact (table build about 3 s, ``benchmarks/vision.py``).

Images are OpenCV's BGR ``uint8`` by default; pass ``order="rgb"`` for RGB images.
Colour triplets given to the density methods (`SkinModel.log_likelihood_ratio`,
`SkinModel.probability`) are always in RGB order, in grey levels 0–255.

One concept, the skin colour classifier, which is why the module is over 600 lines.
"""

from __future__ import annotations

import csv
import functools
import io
import os
from collections.abc import Iterable
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np
from numba import njit

from handvar.atomic import write_atomic
from handvar.validate import as_float, as_int, one_of

__all__ = [
    "SKIN_SETTINGS",
    "GaussianMixture",
    "HistogramSkinModel",
    "SkinModel",
    "SkinSettings",
    "bin_centres",
    "colour_indices",
    "jones_rehg_mixtures",
    "mixture_density",
    "mixture_log_density",
]


@dataclass(frozen=True)
class SkinSettings:
    """Named settings of the skin classifier (paper section 6; Jones & Rehg 2002).

    Attributes
    ----------
    threshold : float
        Likelihood-ratio threshold Θ of the test ``P(c|skin) / P(c|non-skin) >= Θ``.
        Jones & Rehg sweep Θ to trace an ROC curve; their headline operating point (for
        their 32³ histogram model) is 80 % of skin pixels detected at 8.5 % false
        positives, and they find the mixture model slightly below the histogram's ROC.
        We use Θ = 0.5, chosen by looking at the real example video (grey office
        partition, white wall, a yellow toy, a metal cup, a checked shirt; hand and
        forearm in front): at Θ = 1 (equal evidence) the shaded finger edges and the
        pale fingertips are lost (the silhouette lies up to ~5 px inside the fingers);
        at Θ = 0.5 the outline follows them, and the background that passes (white
        wall, toy, shirt) stays in separate components that the clean-up drops; at
        Θ = 0.4 and below the checked shirt starts to merge with the forearm.  Every
        ``mask`` call accepts an override.
    bins : int
        Lookup-table levels per colour channel for the mixture model (a power of two
        dividing 256).  64 keeps the table small (262 144 cells) and the quantisation
        error at most 1.5 grey levels per channel.
    histogram_bins : int
        Levels per channel of the trainable histogram model; Jones & Rehg found 32 the
        best size for their (very large) training set.
    prior : float
        Prior probability of skin π used by `SkinModel.probability` (0.5: no
        preference).  ``probability(c, prior=π) >= 0.5`` is the same decision as the
        ratio test with Θ = (1 − π) / π, so the default Θ = 0.5 corresponds to π = 2/3.
    """

    threshold: float = 0.5
    bins: int = 64
    histogram_bins: int = 32
    prior: float = 0.5


SKIN_SETTINGS = SkinSettings()

_ORDERS = ("bgr", "rgb")


# --- Gaussian mixtures -----------------------------------------------------------------


@dataclass(frozen=True)
class GaussianMixture:
    """A mixture of axis-aligned (diagonal-covariance) Gaussians in RGB.

    Attributes
    ----------
    means : (K, 3) ndarray
        Component means, RGB grey levels.
    variances : (K, 3) ndarray
        Diagonal covariances, grey levels squared.
    weights : (K,) ndarray
        Mixing weights (non-negative; they sum to one up to the rounding of the
        published table, and are renormalised here).
    """

    means: np.ndarray
    variances: np.ndarray
    weights: np.ndarray

    def __post_init__(self) -> None:
        means = np.asarray(self.means, dtype=np.float64)
        variances = np.asarray(self.variances, dtype=np.float64)
        weights = np.asarray(self.weights, dtype=np.float64)
        if means.ndim != 2 or means.shape[1] != 3:
            raise ValueError(f"means: expected shape (K, 3), got {means.shape}")
        if variances.shape != means.shape:
            raise ValueError(
                f"variances: expected shape {means.shape} like means, got {variances.shape}"
            )
        if weights.shape != (means.shape[0],):
            raise ValueError(f"weights: expected shape ({means.shape[0]},), got {weights.shape}")
        if not (np.all(np.isfinite(means)) and np.all(np.isfinite(variances))):
            raise ValueError("means, variances: expected finite values, got NaN or inf")
        if np.any(variances <= 0):
            raise ValueError(f"variances: expected > 0, got minimum {variances.min()}")
        if np.any(weights < 0) or not np.isfinite(weights).all() or weights.sum() <= 0:
            raise ValueError(f"weights: expected finite, >= 0 and not all 0, got {weights}")
        object.__setattr__(self, "means", means)
        object.__setattr__(self, "variances", variances)
        object.__setattr__(self, "weights", weights / weights.sum())

    def log_density(self, rgb: np.ndarray) -> np.ndarray:
        """Log density at RGB colours; see `mixture_log_density`."""
        return mixture_log_density(rgb, self.means, self.variances, self.weights)

    def density(self, rgb: np.ndarray) -> np.ndarray:
        """Density at RGB colours; see `mixture_density`."""
        return np.exp(self.log_density(rgb))


def _as_colours(rgb: np.ndarray, name: str = "rgb") -> np.ndarray:
    """Check colours of shape (..., 3) and return them as float64."""
    arr = np.asarray(rgb, dtype=np.float64)
    if arr.ndim < 1 or arr.shape[-1] != 3:
        raise ValueError(f"{name}: expected shape (..., 3) colours, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: expected finite colour values, got NaN or inf")
    return arr


def mixture_log_density(
    rgb: np.ndarray, means: np.ndarray, variances: np.ndarray, weights: np.ndarray
) -> np.ndarray:
    """Log density of a mixture of diagonal Gaussians (Jones & Rehg 2002, eq. 5).

    ``p(c) = Σ_i w_i (2π)^{-3/2} |Σ_i|^{-1/2} exp(-½ (c − μ_i)ᵀ Σ_i⁻¹ (c − μ_i))``,
    evaluated stably in the log domain (log-sum-exp over components).

    Parameters
    ----------
    rgb : (..., 3) array_like
        Colours, RGB grey levels (any real values).
    means, variances : (K, 3) ndarray
        Component means (levels) and diagonal variances (levels²).
    weights : (K,) ndarray
        Mixing weights summing to one.

    Returns
    -------
    (...) ndarray
        ``log p(c)``, with ``p`` in 1 / level³.
    """
    c = _as_colours(rgb)
    flat = c.reshape(-1, 3)
    # log N(c; μ_i, diag σ²_i) = -½ Σ_k (c_k − μ_ik)² / σ²_ik − ½ Σ_k log(2π σ²_ik)
    log_norm = -0.5 * np.sum(np.log(2.0 * np.pi * variances), axis=1)  # (K,)
    inv = 1.0 / variances
    # Expand the quadratic form so the work is one (N, 3) × (3, K) product per term.
    quad = (
        (flat * flat) @ inv.T
        - 2.0 * flat @ (means * inv).T
        + np.sum(means * means * inv, axis=1)[None, :]
    )  # (N, K)
    terms = np.log(weights)[None, :] + log_norm[None, :] - 0.5 * quad
    top = terms.max(axis=1, keepdims=True)
    out = top[:, 0] + np.log(np.exp(terms - top).sum(axis=1))
    return out.reshape(c.shape[:-1])


def mixture_density(
    rgb: np.ndarray, means: np.ndarray, variances: np.ndarray, weights: np.ndarray
) -> np.ndarray:
    """Density of a mixture of diagonal Gaussians; ``exp`` of `mixture_log_density`.

    Returns
    -------
    (...) ndarray
        ``p(c)`` in 1 / level³ for colours ``rgb`` of shape (..., 3).
    """
    return np.exp(mixture_log_density(rgb, means, variances, weights))


@functools.cache
def jones_rehg_mixtures() -> tuple[GaussianMixture, GaussianMixture]:
    """The published Jones–Rehg skin and non-skin mixtures (16 components each).

    Read from the package data file ``handvar/data/jones-rehg-skin-gmm.csv`` (columns
    ``class, component, mean_r, mean_g, mean_b, var_r, var_g, var_b, weight``); see
    ``handvar/data/README.md`` for provenance.

    Returns
    -------
    skin, nonskin : GaussianMixture
    """
    text = resources.files("handvar").joinpath("data/jones-rehg-skin-gmm.csv").read_text("utf-8")
    rows: dict[str, list[list[float]]] = {"skin": [], "nonskin": []}
    for row in csv.DictReader(io.StringIO(text)):
        cls = row["class"].strip()
        if cls not in rows:
            raise ValueError(f"jones-rehg-skin-gmm.csv: expected class skin/nonskin, got {cls!r}")
        rows[cls].append(
            [float(row[k]) for k in ("mean_r", "mean_g", "mean_b", "var_r", "var_g", "var_b")]
            + [float(row["weight"])]
        )
    out = []
    for cls in ("skin", "nonskin"):
        table = np.array(rows[cls])
        if table.shape != (16, 7):
            raise ValueError(
                f"jones-rehg-skin-gmm.csv: expected 16 {cls} components, got {len(rows[cls])}"
            )
        out.append(GaussianMixture(table[:, 0:3], table[:, 3:6], table[:, 6]))
    return out[0], out[1]


# --- colour lookup tables --------------------------------------------------------------


def _check_bins(bins: int, name: str = "bins") -> int:
    bins = as_int(bins, name, minimum=2, maximum=256)
    if bins & (bins - 1):
        raise ValueError(f"{name}: expected a power of two in [2, 256]; got {bins}")
    return bins


def bin_centres(bins: int) -> np.ndarray:
    """Centres of the ``bins`` equal bins that split the grey levels 0–255.

    Bin ``k`` holds the levels ``k·w … k·w + w − 1`` with ``w = 256 / bins``; its centre
    is ``k·w + (w − 1) / 2``, so no level is more than ``(w − 1) / 2`` from its centre.

    Returns
    -------
    (bins,) ndarray
        Centres in grey levels.
    """
    bins = _check_bins(bins)
    w = 256 // bins
    return np.arange(bins) * w + (w - 1) / 2.0


def _check_image(image: np.ndarray, name: str = "image") -> np.ndarray:
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8:
        dtype = getattr(image, "dtype", type(image).__name__)
        raise ValueError(f"{name}: expected a uint8 colour image; got dtype {dtype}")
    if image.ndim != 3 or image.shape[2] != 3:
        raise ValueError(f"{name}: expected shape (H, W, 3); got {image.shape}")
    return image


def colour_indices(image: np.ndarray, bins: int, *, order: str = "bgr") -> np.ndarray:
    """Flat lookup-table index of every pixel of an 8-bit colour image.

    The index of the colour (r, g, b) is ``(r >> s) · bins² + (g >> s) · bins + (b >> s)``
    with ``s = log2(256 / bins)``, i.e. C order over a ``(bins, bins, bins)`` table
    indexed ``[r_bin, g_bin, b_bin]``.

    Parameters
    ----------
    image : (H, W, 3) uint8 ndarray
        Colour image, BGR (OpenCV's order) unless ``order="rgb"``.
    bins : int
        Levels per channel, a power of two in 2..256.
    order : {"bgr", "rgb"}
        Channel order of ``image``.

    Returns
    -------
    (H, W) uint32 ndarray
        Indices into the flattened table, in ``0 .. bins**3 − 1``.
    """
    image = _check_image(image)
    bins = _check_bins(bins)
    order = one_of(order, _ORDERS, "order")
    k = bins.bit_length() - 1  # log2(bins)
    shift = 8 - k
    q = image >> shift if shift else image
    r, b = (2, 0) if order == "bgr" else (0, 2)
    idx = q[..., r].astype(np.uint32) << (2 * k)
    idx |= q[..., 1].astype(np.uint32) << k
    idx |= q[..., b]
    return idx


@njit(cache=True)
def _gather_kernel(image, table, shift, k, r, b, out):  # pragma: no cover
    """out[y, x] = table[colour_indices(image)[y, x]] in one pass over the pixels.

    The same arithmetic as `colour_indices` followed by ``table.take``, compiled so
    that a full-HD frame is classified without the three full-size temporaries.
    """
    h, w = out.shape
    for y in range(h):
        for x in range(w):
            idx = (
                ((image[y, x, r] >> shift) << (2 * k))
                | ((image[y, x, 1] >> shift) << k)
                | (image[y, x, b] >> shift)
            )
            out[y, x] = table[idx]


def _gather(table: np.ndarray, image: np.ndarray, bins: int, order: str) -> np.ndarray:
    """``table.ravel().take(colour_indices(image, bins, order=order))``, compiled."""
    image = _check_image(image)
    bins = _check_bins(bins)
    order = one_of(order, _ORDERS, "order")
    k = bins.bit_length() - 1
    r, b = (2, 0) if order == "bgr" else (0, 2)
    out = np.empty(image.shape[:2], dtype=table.dtype)
    _gather_kernel(np.ascontiguousarray(image), table.ravel(), 8 - k, k, r, b, out)
    return out


class _TableClassifier:
    """Classification of images through a log-likelihood-ratio lookup table."""

    bins: int

    def _log_ratio_table(self) -> np.ndarray:  # pragma: no cover - overridden
        raise NotImplementedError

    @property
    def table(self) -> np.ndarray:
        """(bins, bins, bins) float ndarray: log likelihood ratio per colour cell.

        Indexed ``[r_bin, g_bin, b_bin]``; ``-inf``/``+inf`` where a density is zero.
        """
        return self._log_ratio_table().reshape(self.bins, self.bins, self.bins)

    def log_ratio_image(self, image: np.ndarray, *, order: str = "bgr") -> np.ndarray:
        """Log likelihood ratio ``log P(c|skin) − log P(c|non-skin)`` of every pixel.

        Parameters
        ----------
        image : (H, W, 3) uint8 ndarray
            Colour image, BGR unless ``order="rgb"``.
        order : {"bgr", "rgb"}
            Channel order of ``image``.

        Returns
        -------
        (H, W) float32 ndarray
            Tabulated log ratio (natural log) of each pixel's colour cell.
        """
        return _gather(self._log_ratio_table(), image, self.bins, order)

    def mask(
        self, image: np.ndarray, *, threshold: float | None = None, order: str = "bgr"
    ) -> np.ndarray:
        """Skin mask by the likelihood-ratio test ``P(c|skin) / P(c|non-skin) >= Θ``.

        Parameters
        ----------
        image : (H, W, 3) uint8 ndarray
            Colour image, BGR (OpenCV's order) unless ``order="rgb"``.
        threshold : float, optional
            The ratio threshold Θ > 0 (not its log); default
            ``SKIN_SETTINGS.threshold`` (see `SkinSettings`).
        order : {"bgr", "rgb"}
            Channel order of ``image``.

        Returns
        -------
        (H, W) bool ndarray
            True where the pixel is classified as skin.
        """
        theta = SKIN_SETTINGS.threshold if threshold is None else threshold
        theta = as_float(theta, "threshold", minimum=0, exclusive_minimum=True)
        cache = getattr(self, "_mask_cache", None)
        if cache is None or cache[0] != theta:
            # One boolean table per threshold: the test becomes a single gather.
            cache = (theta, self._log_ratio_table() >= np.log(theta))
            self._mask_cache = cache
        return _gather(cache[1], image, self.bins, order)


class SkinModel(_TableClassifier):
    """Skin / non-skin classifier from two Gaussian mixtures (default: Jones & Rehg).

    Parameters
    ----------
    skin, nonskin : GaussianMixture, optional
        Class-conditional colour densities; both default to the published Jones–Rehg
        16-component mixtures (`jones_rehg_mixtures`).
    bins : int, optional
        Levels per channel of the lookup table used for images (default
        ``SKIN_SETTINGS.bins`` = 64).  The table holds the exact log ratio at the bin
        centres (`bin_centres`) and is built on first use (about 0.1 s for 64 bins),
        then cached.  With 64 bins a colour is at most 1.5 levels per channel from
        its bin centre; the tabulated log ratio is within 0.21 (median) / 1.2 (99th
        percentile) of the exact one, and the decision at Θ = 0.5 changes for 0.6 % of
        colours (see the module docstring); ``bins=256`` is exact.

    Examples
    --------
    >>> import numpy as np
    >>> model = SkinModel()
    >>> bool(model.log_likelihood_ratio([200, 140, 110]) > 0)   # a typical skin tone
    True
    >>> bool(model.log_likelihood_ratio([90, 100, 110]) > 0)    # grey-blue
    False
    >>> image = np.full((2, 3, 3), (110, 140, 200), np.uint8)  # BGR skin tone
    >>> model.mask(image).all()
    np.True_
    """

    def __init__(
        self,
        skin: GaussianMixture | None = None,
        nonskin: GaussianMixture | None = None,
        *,
        bins: int = SKIN_SETTINGS.bins,
    ) -> None:
        if (skin is None) != (nonskin is None):
            raise ValueError("skin, nonskin: expected both mixtures or neither, got one")
        if skin is None:
            skin, nonskin = jones_rehg_mixtures()
        for name, mix in (("skin", skin), ("nonskin", nonskin)):
            if not isinstance(mix, GaussianMixture):
                raise ValueError(f"{name}: expected a GaussianMixture, got {type(mix).__name__}")
        self.skin = skin
        self.nonskin = nonskin
        self.bins = _check_bins(bins)
        self._flat_table: np.ndarray | None = None

    def __repr__(self) -> str:
        return (
            f"SkinModel({len(self.skin.weights)}+{len(self.nonskin.weights)} components, "
            f"bins={self.bins})"
        )

    def log_likelihood_ratio(self, rgb: np.ndarray) -> np.ndarray:
        """Exact log likelihood ratio ``log p(c|skin) − log p(c|non-skin)``.

        Parameters
        ----------
        rgb : (..., 3) array_like
            Colours in RGB order, grey levels (real values allowed).

        Returns
        -------
        (...) ndarray
            Natural-log likelihood ratio (dimensionless).
        """
        c = _as_colours(rgb)
        return self.skin.log_density(c) - self.nonskin.log_density(c)

    def probability(self, rgb: np.ndarray, *, prior: float = SKIN_SETTINGS.prior) -> np.ndarray:
        """Posterior probability of skin by Bayes' rule.

        ``P(skin|c) = 1 / (1 + exp(−(log LR(c) + log(π / (1 − π)))))`` with prior π.

        Parameters
        ----------
        rgb : (..., 3) array_like
            Colours in RGB order, grey levels.
        prior : float
            Prior probability of skin, in (0, 1).

        Returns
        -------
        (...) ndarray
            Posterior probabilities in [0, 1].
        """
        prior = float(prior)
        if not 0.0 < prior < 1.0:
            raise ValueError(f"prior: expected a probability in (0, 1), got {prior}")
        z = self.log_likelihood_ratio(rgb) + np.log(prior) - np.log1p(-prior)
        # Logistic function written to avoid overflow for large |z|.
        ez = np.exp(-np.abs(z))
        return np.where(z >= 0, 1.0 / (1.0 + ez), ez / (1.0 + ez))

    def _log_ratio_table(self) -> np.ndarray:
        if self._flat_table is None:
            c = bin_centres(self.bins)
            table = _grid_log_density(self.skin, c) - _grid_log_density(self.nonskin, c)
            self._flat_table = table.ravel().astype(np.float32)
        return self._flat_table


def _grid_log_density(mix: GaussianMixture, centres: np.ndarray) -> np.ndarray:
    """Mixture log density on the grid ``centres × centres × centres`` (r, g, b).

    The same value as `mixture_log_density` at every grid point, computed separably:
    a diagonal Gaussian's exponent is a sum of one term per channel, so each component
    costs one broadcast sum, and components are accumulated with ``logaddexp``.

    Returns
    -------
    (n, n, n) ndarray
        ``log p`` indexed ``[r, g, b]``, ``n = len(centres)``.
    """
    n = len(centres)
    d = centres[None, :, None] - mix.means[:, None, :]  # (K, n, 3)
    q = -0.5 * d * d / mix.variances[:, None, :]  # per-channel exponents, (K, n, 3)
    log_norm = np.log(mix.weights) - 0.5 * np.sum(np.log(2.0 * np.pi * mix.variances), axis=1)
    # eq. 5 of Jones & Rehg per component, log w_k + log N(c; μ_k, diag σ²_k), summed
    # over k as log-sum-exp (shifted by the largest term), a slab of red levels at once
    # so that the (K, slab, n, n) terms stay near 32 MB (scipy.special.logsumexp gives
    # the same but, with its extra passes, builds the table several times slower)
    rg = q[:, :, 0][:, :, None] + q[:, :, 1][:, None, :]  # (K, n, n)
    b = (q[:, :, 2] + log_norm[:, None])[:, None, None, :]  # (K, 1, 1, n)
    out = np.empty((n, n, n))
    slab = max(1, (1 << 22) // (len(log_norm) * n * n))
    for r in range(0, n, slab):
        terms = rg[:, r : r + slab, :, None] + b
        top = terms.max(axis=0)
        np.subtract(terms, top, out=terms)
        np.exp(terms, out=terms)
        out[r : r + slab] = top + np.log(terms.sum(axis=0))
    return out


# --- trainable histogram model ---------------------------------------------------------


class HistogramSkinModel(_TableClassifier):
    """Skin / non-skin colour histograms (Jones & Rehg's histogram model).

    ``P(c|skin) = s[c] / Σ s`` and ``P(c|non-skin) = n[c] / Σ n`` with ``s``, ``n`` the
    counts of labelled skin and non-skin pixels per colour cell; the mask is the same
    likelihood-ratio test as `SkinModel.mask`.  A cell never seen as skin has ratio 0
    (never skin); a cell seen only as skin has ratio ∞ (always skin).

    Parameters
    ----------
    skin_counts, nonskin_counts : (bins, bins, bins) array_like
        Non-negative counts indexed ``[r_bin, g_bin, b_bin]``, each with a positive total.

    See Also
    --------
    HistogramSkinModel.fit : count the histograms from labelled images.
    """

    def __init__(self, skin_counts: np.ndarray, nonskin_counts: np.ndarray) -> None:
        s = np.asarray(skin_counts, dtype=np.float64)
        n = np.asarray(nonskin_counts, dtype=np.float64)
        if s.ndim != 3 or s.shape[0] != s.shape[1] or s.shape[1] != s.shape[2]:
            raise ValueError(f"skin_counts: expected shape (bins, bins, bins), got {s.shape}")
        _check_bins(s.shape[0], "skin_counts bins")
        if n.shape != s.shape:
            raise ValueError(f"nonskin_counts: expected shape {s.shape}, got {n.shape}")
        for name, h in (("skin_counts", s), ("nonskin_counts", n)):
            if not np.all(np.isfinite(h)) or np.any(h < 0):
                raise ValueError(f"{name}: expected finite counts >= 0, got negative or NaN")
            if h.sum() <= 0:
                raise ValueError(f"{name}: expected at least one counted pixel, got none")
        self.skin_counts = s
        self.nonskin_counts = n
        self.bins = s.shape[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            ls = np.log(s.ravel() / s.sum())
            ln = np.log(n.ravel() / n.sum())
            table = ls - ln
        # 0/0 (never seen): not skin.
        table[np.isnan(table)] = -np.inf
        self._flat_table = table.astype(np.float32)

    def __repr__(self) -> str:
        return (
            f"HistogramSkinModel(bins={self.bins}, skin={int(self.skin_counts.sum())} px, "
            f"nonskin={int(self.nonskin_counts.sum())} px)"
        )

    def _log_ratio_table(self) -> np.ndarray:
        return self._flat_table

    @classmethod
    def fit(
        cls,
        images: Iterable[np.ndarray],
        masks: Iterable[np.ndarray],
        *,
        bins: int = SKIN_SETTINGS.histogram_bins,
        order: str = "bgr",
    ) -> HistogramSkinModel:
        """Count skin and non-skin colours in labelled images.

        Parameters
        ----------
        images : iterable of (H, W, 3) uint8 ndarray
            Colour images, BGR unless ``order="rgb"``.
        masks : iterable of (H, W) array_like of bool
            Ground-truth skin labels, one per image (same height and width).
        bins : int
            Levels per channel, a power of two in 2..256 (default 32, as Jones & Rehg).
        order : {"bgr", "rgb"}
            Channel order of the images.

        Returns
        -------
        HistogramSkinModel
        """
        bins = _check_bins(bins)
        s = np.zeros(bins**3, dtype=np.int64)
        n = np.zeros(bins**3, dtype=np.int64)
        images = list(images)
        masks = list(masks)
        if len(images) != len(masks):
            raise ValueError(
                f"masks: expected one mask per image ({len(images)}), got {len(masks)}"
            )
        if not images:
            raise ValueError("images: expected at least one labelled image, got none")
        for i, (image, m) in enumerate(zip(images, masks, strict=True)):
            idx = colour_indices(_check_image(image, f"images[{i}]"), bins, order=order)
            m = np.asarray(m)
            if m.shape != idx.shape:
                raise ValueError(f"masks[{i}]: expected shape {idx.shape}, got {m.shape}")
            m = m.astype(bool)
            s += np.bincount(idx[m], minlength=bins**3)
            n += np.bincount(idx[~m], minlength=bins**3)
        shape = (bins, bins, bins)
        return cls(s.reshape(shape), n.reshape(shape))

    def save(self, path: str | os.PathLike) -> Path:
        """Write the counts to an ``.npz`` file atomically (temporary file, then rename).

        Parameters
        ----------
        path : str or path-like
            Destination file, written as given (no ``.npz`` suffix is appended).

        Returns
        -------
        Path
            The written path.
        """
        path = Path(path)

        def write(tmp: str) -> None:
            with open(tmp, "wb") as f:  # a file object: np.savez adds no suffix
                np.savez_compressed(
                    f, skin_counts=self.skin_counts, nonskin_counts=self.nonskin_counts
                )

        write_atomic(path, write)
        return path

    @classmethod
    def load(cls, path: str | os.PathLike) -> HistogramSkinModel:
        """Read a model written by `save`.

        Raises
        ------
        ValueError
            If the file is not a histogram model (missing arrays, wrong shapes).
        """
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as data:
                s, n = data["skin_counts"], data["nonskin_counts"]
        except (KeyError, ValueError, OSError) as exc:
            if isinstance(exc, FileNotFoundError):
                raise
            raise ValueError(
                f"path: expected an npz file with skin_counts and nonskin_counts, got {path} "
                f"({exc})"
            ) from exc
        return cls(s, n)
