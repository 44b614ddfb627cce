"""Tests of handvar.vision.skin: Jones–Rehg mixtures, lookup tables, histogram model."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy import stats

from handvar.vision.skin import (
    SKIN_SETTINGS,
    GaussianMixture,
    HistogramSkinModel,
    SkinModel,
    bin_centres,
    colour_indices,
    jones_rehg_mixtures,
    mixture_density,
)

# Typical skin tones (RGB), from light to dark; all are clearly skin for the Jones–Rehg
# mixtures (log ratio between 1.2 and 3.9).
SKIN_TONES = np.array(
    [
        (233, 190, 160),
        (225, 172, 140),
        (198, 134, 100),
        (170, 112, 80),
        (141, 85, 60),
        (224, 172, 105),
        (198, 134, 66),
    ],
    dtype=np.float64,
)
# Background palette (RGB): greys, blues, greens, purples, yellow, near white, near
# black.  Reds, oranges and browns are left out on purpose: a colour model cannot tell
# them from skin, which is why the silhouette clean-up keeps the largest component.
BACKGROUND = np.array(
    [
        (128, 128, 128),
        (60, 90, 160),
        (40, 140, 60),
        (200, 200, 210),
        (30, 30, 30),
        (90, 60, 140),
        (20, 100, 120),
        (230, 230, 80),
        (240, 240, 240),
        (160, 165, 170),
    ],
    dtype=np.float64,
)


def synthetic_frame(
    rng: np.random.Generator,
    h: int = 240,
    w: int = 320,
    n_blobs: int = 3,
    tone: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """A cluttered BGR frame with skin-coloured blobs, and the blobs' true mask.

    ``tone`` is the RGB skin colour (default: one of `SKIN_TONES` at random).
    """
    img = np.empty((h, w, 3), np.float64)
    img[:] = BACKGROUND[rng.integers(len(BACKGROUND))]
    for _ in range(30):  # clutter: rectangles and ellipses of background colours
        colour = BACKGROUND[rng.integers(len(BACKGROUND))] + rng.uniform(-15, 15, 3)
        x0, y0 = rng.integers(0, w), rng.integers(0, h)
        if rng.random() < 0.5:
            x1, y1 = x0 + rng.integers(10, 120), y0 + rng.integers(10, 90)
            cv2.rectangle(img, (int(x0), int(y0)), (int(x1), int(y1)), colour.tolist(), -1)
        else:
            axes = (int(rng.integers(5, 60)), int(rng.integers(5, 40)))
            ang = float(rng.uniform(0, 180))
            cv2.ellipse(img, (int(x0), int(y0)), axes, ang, 0, 360, colour.tolist(), -1)
    mask = np.zeros((h, w), np.uint8)
    tone = SKIN_TONES[rng.integers(len(SKIN_TONES))] if tone is None else tone
    for _ in range(n_blobs):
        blob = np.zeros_like(mask)
        centre = (int(rng.integers(w // 6, w - w // 6)), int(rng.integers(h // 6, h - h // 6)))
        axes = (int(rng.integers(15, 45)), int(rng.integers(15, 35)))
        cv2.ellipse(blob, centre, axes, float(rng.uniform(0, 180)), 0, 360, 1, -1)
        for _ in range(4):  # fingers
            end = (centre[0] + int(rng.integers(-70, 70)), centre[1] + int(rng.integers(-70, 70)))
            cv2.line(blob, centre, end, 1, int(rng.integers(8, 16)))
        mask |= blob
    # Skin with smooth shading (±10 %) across the frame.
    shade = 0.9 + 0.2 * np.linspace(0, 1, w)[None, :] * np.ones((h, 1))
    skin = tone[None, None, :] * shade[..., None]
    img = np.where(mask[..., None] > 0, skin, img)
    img += rng.normal(0, 4, img.shape)  # sensor noise
    bgr = np.clip(np.rint(img[..., ::-1]), 0, 255).astype(np.uint8)
    return bgr, mask > 0


def iou(a: np.ndarray, b: np.ndarray) -> float:
    return float((a & b).sum() / max((a | b).sum(), 1))


@pytest.fixture(scope="module")
def model() -> SkinModel:
    return SkinModel()


# --- the mixtures -----------------------------------------------------------------------


def test_published_mixtures_have_16_components_and_unit_weight():
    skin, nonskin = jones_rehg_mixtures()
    for mix in (skin, nonskin):
        assert mix.means.shape == (16, 3)
        assert mix.variances.shape == (16, 3)
        np.testing.assert_allclose(mix.weights.sum(), 1.0, rtol=1e-12)
    # Raw table values (IJCV 2002, table of the skin mixture): first component.
    np.testing.assert_allclose(skin.means[0], [73.53, 29.94, 17.76])
    np.testing.assert_allclose(skin.variances[0], [765.4, 121.44, 112.8])


def test_mixture_density_matches_scipy_multivariate_normal():
    rng = np.random.default_rng(0)
    for mix in jones_rehg_mixtures():
        colours = rng.uniform(0, 255, size=(7, 3))
        expected = sum(
            w * stats.multivariate_normal(mean=mu, cov=np.diag(var)).pdf(colours)
            for mu, var, w in zip(mix.means, mix.variances, mix.weights, strict=True)
        )
        got = mixture_density(colours, mix.means, mix.variances, mix.weights)
        np.testing.assert_allclose(got, expected, rtol=1e-10)
        np.testing.assert_allclose(mix.density(colours), expected, rtol=1e-10)


def test_mixture_density_integrates_to_one():
    # Riemann sum over a box covering every component by 7 standard deviations, for a
    # two-component mixture with the published first skin components.  The midpoint
    # rule on a step of 3 levels (σ >= 10 levels here) is accurate far beyond 1e-3.
    skin, _ = jones_rehg_mixtures()
    mix = GaussianMixture(skin.means[:2], skin.variances[:2], skin.weights[:2])
    sd = np.sqrt(mix.variances)
    lo = (mix.means - 7 * sd).min(axis=0)
    hi = (mix.means + 7 * sd).max(axis=0)
    step = 3.0
    axes = [np.arange(a, b, step) + step / 2 for a, b in zip(lo, hi, strict=True)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    total = mix.density(grid).sum() * step**3
    np.testing.assert_allclose(total, 1.0, rtol=1e-3)


def test_probability_is_bayes_rule(model):
    skin, nonskin = jones_rehg_mixtures()
    colours = np.array([[200.0, 140, 110], [90, 100, 110], [250, 250, 250], [141, 85, 36]])
    for prior in (0.1, 0.5, 0.9):
        ps, pn = skin.density(colours), nonskin.density(colours)
        expected = prior * ps / (prior * ps + (1 - prior) * pn)
        np.testing.assert_allclose(model.probability(colours, prior=prior), expected, rtol=1e-9)
    with pytest.raises(ValueError, match="prior"):
        model.probability(colours, prior=1.0)


def test_log_likelihood_ratio_shapes(model):
    rgb = np.full((4, 5, 3), 128.0)
    assert model.log_likelihood_ratio(rgb).shape == (4, 5)
    assert model.log_likelihood_ratio([1, 2, 3]).shape == ()
    with pytest.raises(ValueError, match=r"rgb: expected shape \(\.\.\., 3\)"):
        model.log_likelihood_ratio(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="finite"):
        model.log_likelihood_ratio([np.nan, 1, 2])


# --- the lookup table -------------------------------------------------------------------


def test_bin_centres():
    np.testing.assert_array_equal(bin_centres(64)[:3], [1.5, 5.5, 9.5])
    np.testing.assert_array_equal(bin_centres(256), np.arange(256))
    assert bin_centres(2).tolist() == [63.5, 191.5]
    for bad in (0, 3, 512):
        with pytest.raises(ValueError, match="bins"):
            bin_centres(bad)
    for bad in (64.0, True):
        with pytest.raises(TypeError, match="bins"):
            bin_centres(bad)


def test_colour_indices_match_ravel_multi_index():
    rng = np.random.default_rng(1)
    img = rng.integers(0, 256, (17, 23, 3), dtype=np.uint8)
    for bins in (2, 32, 64, 256):
        w = 256 // bins
        b, g, r = (img[..., k] // w for k in range(3))
        expected = np.ravel_multi_index((r, g, b), (bins, bins, bins))
        np.testing.assert_array_equal(colour_indices(img, bins), expected)
        np.testing.assert_array_equal(colour_indices(img[..., ::-1], bins, order="rgb"), expected)


@pytest.mark.parametrize("bins", [64, 128])  # 128: the table is built in slabs
def test_table_equals_mixture_at_bin_centres(model, bins):
    if bins != model.bins:
        model = SkinModel(bins=bins)
    c = bin_centres(model.bins)
    rng = np.random.default_rng(2)
    ijk = rng.integers(0, model.bins, size=(500, 3))
    exact = model.log_likelihood_ratio(c[ijk])
    np.testing.assert_allclose(model.table[ijk[:, 0], ijk[:, 1], ijk[:, 2]], exact, rtol=1e-6)


def test_table_matches_mixture_within_quantisation_error(model):
    # Stated in the module docstring: median 0.21, 99th percentile 1.2 (64 bins).
    rng = np.random.default_rng(3)
    rgb = rng.integers(0, 256, (200_000, 3))
    exact = model.log_likelihood_ratio(rgb)
    image = rgb[:, None, ::-1].astype(np.uint8)  # as a BGR column image
    tab = model.log_ratio_image(image)[:, 0]
    err = np.abs(tab - exact)
    assert np.median(err) < 0.25
    assert np.percentile(err, 99) < 1.3
    # Decisions agree wherever the exact ratio is not close to the threshold.
    clear = np.abs(exact) > 2.0
    np.testing.assert_array_equal(model.mask(image)[:, 0][clear], exact[clear] >= 0)


def test_mask_threshold_and_order(model):
    rng = np.random.default_rng(5)
    img = rng.integers(0, 256, (40, 60, 3), dtype=np.uint8)
    llr = model.log_ratio_image(img)
    for theta in (0.4, 1.0, 4.0):
        np.testing.assert_array_equal(
            model.mask(img, threshold=theta), llr >= np.float32(np.log(theta))
        )
    np.testing.assert_array_equal(model.mask(img), llr >= np.log(SKIN_SETTINGS.threshold))
    np.testing.assert_array_equal(model.mask(img), model.mask(img[..., ::-1].copy(), order="rgb"))


@pytest.mark.parametrize(
    ("kwargs", "match", "error"),
    [
        ({"image": np.zeros((4, 4, 3), np.float32)}, "image: expected a uint8", ValueError),
        ({"image": np.zeros((4, 4), np.uint8)}, r"image: expected shape \(H, W, 3\)", ValueError),
        ({"image": np.zeros((4, 4, 3), np.uint8), "order": "hsv"}, "order", ValueError),
        ({"image": np.zeros((4, 4, 3), np.uint8), "threshold": 0.0}, "threshold", ValueError),
        ({"image": np.zeros((4, 4, 3), np.uint8), "threshold": "1"}, "threshold", TypeError),
    ],
)
def test_mask_rejects_bad_input(model, kwargs, match, error):
    image = kwargs.pop("image")
    with pytest.raises(error, match=match):
        model.mask(image, **kwargs)


def test_mixture_validation():
    with pytest.raises(ValueError, match="variances"):
        GaussianMixture(np.zeros((2, 3)), np.zeros((2, 3)), np.ones(2))
    with pytest.raises(ValueError, match="means"):
        GaussianMixture(np.zeros((2, 2)), np.ones((2, 2)), np.ones(2))
    with pytest.raises(ValueError, match="skin, nonskin"):
        SkinModel(skin=jones_rehg_mixtures()[0])


# --- synthetic frames -------------------------------------------------------------------


def test_skin_mask_recovers_synthetic_blobs(model):
    # The pure likelihood-ratio test at equal evidence (Θ = 1), then the clean-up.
    from handvar.vision.silhouette import clean_mask

    rng = np.random.default_rng(6)
    raw_scores, clean_scores = [], []
    for _ in range(8):
        frame, truth = synthetic_frame(rng)
        raw = model.mask(frame, threshold=1.0)
        raw_scores.append(iou(raw, truth))
        cleaned = clean_mask(raw, keep=10, min_area=50)
        clean_scores.append(iou(cleaned, truth))
    assert min(raw_scores) >= 0.9, raw_scores
    assert min(clean_scores) >= 0.9, clean_scores


def test_default_silhouette_of_one_synthetic_hand(model):
    # Default threshold (Θ = 0.5) and clean-up (largest component) on frames with one
    # hand-like blob.  At Θ = 0.5 part of the pale-cream and yellow clutter passes as
    # skin; where such clutter touches the hand it merges, which is what the stricter
    # Θ = 1 avoids at the cost of shaded skin on real video.  The clean-up's opening of
    # 1 px (chosen on the realistic benchmark, `CleanupSettings`) removes less of that
    # clutter than the 2 px before: IoU >= 0.9 on 26 of these 36 frames (33 before),
    # median 0.995 (0.987 before), printed with ``-s``.
    from handvar.vision.silhouette import clean_mask

    rng = np.random.default_rng(6)
    scores = []
    for _ in range(36):
        frame, truth = synthetic_frame(rng, n_blobs=1)
        scores.append(iou(clean_mask(model.mask(frame)), truth))
    good = int(np.sum(np.array(scores) >= 0.9))
    print(f"IoU >= 0.9 on {good} of {len(scores)} frames, median {np.median(scores):.3f}")
    assert good >= 2 / 3 * len(scores), scores
    assert np.median(scores) >= 0.95, scores


# --- the histogram model ----------------------------------------------------------------


def test_histogram_counts_match_histogramdd():
    rng = np.random.default_rng(7)
    frame, truth = synthetic_frame(rng, 60, 80)
    hist = HistogramSkinModel.fit([frame], [truth], bins=32)
    rgb = frame[..., ::-1].reshape(-1, 3)
    edges = [np.arange(0, 257, 8)] * 3
    s, _ = np.histogramdd(rgb[truth.ravel()], bins=edges)
    n, _ = np.histogramdd(rgb[~truth.ravel()], bins=edges)
    np.testing.assert_array_equal(hist.skin_counts, s)
    np.testing.assert_array_equal(hist.nonskin_counts, n)


def test_histogram_model_recovers_held_out_masks():
    rng = np.random.default_rng(8)
    # A histogram knows only the colours it has seen: train on every tone once.
    train = [synthetic_frame(rng, tone=tone) for tone in SKIN_TONES]
    test = [synthetic_frame(rng) for _ in range(4)]
    hist = HistogramSkinModel.fit([f for f, _ in train], [m for _, m in train], bins=32)
    scores = [iou(hist.mask(f), m) for f, m in test]
    assert min(scores) >= 0.9, scores
    # The same decision on RGB input.
    f, _ = test[0]
    np.testing.assert_array_equal(hist.mask(f), hist.mask(f[..., ::-1].copy(), order="rgb"))


def test_histogram_save_load_round_trip(tmp_path):
    rng = np.random.default_rng(9)
    frame, truth = synthetic_frame(rng, 50, 70)
    hist = HistogramSkinModel.fit([frame], [truth], bins=16)
    path = hist.save(tmp_path / "skin.npz")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["skin.npz"]  # no temporary left
    back = HistogramSkinModel.load(path)
    np.testing.assert_array_equal(back.skin_counts, hist.skin_counts)
    np.testing.assert_array_equal(back.nonskin_counts, hist.nonskin_counts)
    np.testing.assert_array_equal(back.mask(frame), hist.mask(frame))
    np.testing.assert_array_equal(back.table, hist.table)


def test_histogram_rejects_bad_input(tmp_path):
    frame = np.zeros((4, 5, 3), np.uint8)
    with pytest.raises(ValueError, match="masks"):
        HistogramSkinModel.fit([frame], [])
    with pytest.raises(ValueError, match=r"masks\[0\]: expected shape \(4, 5\)"):
        HistogramSkinModel.fit([frame], [np.zeros((5, 4), bool)])
    with pytest.raises(ValueError, match="skin_counts: expected at least one"):
        HistogramSkinModel.fit([frame], [np.zeros((4, 5), bool)])
    bad = tmp_path / "bad.npz"
    np.savez(bad, something=np.zeros(3))
    with pytest.raises(ValueError, match="path: expected an npz file"):
        HistogramSkinModel.load(bad)
    with pytest.raises(FileNotFoundError):
        HistogramSkinModel.load(tmp_path / "missing.npz")


@pytest.mark.parametrize("order", ["bgr", "rgb"])
def test_compiled_lookup_equals_index_and_take(order):
    # The mask's one-pass gather against the two-step numpy route.
    from handvar.vision.skin import _gather, colour_indices

    rng = np.random.default_rng(4)
    image = rng.integers(0, 256, (37, 53, 3), dtype=np.uint8)
    model = SkinModel(bins=32)
    table = model.table
    expected = table.ravel().take(colour_indices(image, 32, order=order))
    np.testing.assert_array_equal(_gather(table, image, 32, order), expected)
    np.testing.assert_array_equal(
        model.mask(image, threshold=0.7, order=order), expected >= np.log(0.7)
    )
