"""The adaptive bank, the One Euro filter and the offline-trained VAR (design §16)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from handvar.data import example_path
from handvar.evaluation.openloop import (
    BASELINES,
    Recording,
    keypoint_blocks,
    league_predictors,
    noise_variants,
    smooth_variants,
    synthetic_families,
)
from handvar.predictors import (
    EXPERTS,
    STEERING_EXPERTS,
    AdaptiveBank,
    Decelerating,
    KalmanCV,
    NoMotion,
    OfflineVAR,
    OneEuro,
    hand_blocks,
    hand_groups,
    one_step_predictions,
    second_differences,
)


# --- One Euro: against a literal transcription of the CHI 2012 algorithm -------------
def _one_euro_reference(xs, rate, min_cutoff, beta, d_cutoff):
    """The paper's pseudo-code, one scalar at a time, written as plainly as possible."""

    def alpha(rate, cutoff):
        te = 1.0 / rate
        tau = 1.0 / (2 * math.pi * cutoff)
        return 1.0 / (1.0 + tau / te)

    out, x_prev, dx_prev = [], None, None
    for x in xs:
        if x_prev is None:
            dx_hat, x_hat = 0.0, x
        else:
            dx = (x - x_prev) * rate
            dx_hat = alpha(rate, d_cutoff) * dx + (1 - alpha(rate, d_cutoff)) * dx_prev
            cutoff = min_cutoff + beta * abs(dx_hat)
            x_hat = alpha(rate, cutoff) * x + (1 - alpha(rate, cutoff)) * x_prev
        x_prev, dx_prev = x_hat, dx_hat
        out.append(x_hat)
    return np.array(out)


@pytest.mark.parametrize("beta", [0.0, 0.05])
def test_one_euro_equals_the_papers_algorithm(beta):
    rng = np.random.default_rng(3)
    X = np.cumsum(rng.standard_normal((300, 4)), axis=0)
    f = OneEuro(min_cutoff=0.7, beta=beta, d_cutoff=1.3, rate=60.0)
    ours = []
    for x in X:
        f.update(x)
        ours.append(f.predict())
    ref = np.stack([_one_euro_reference(X[:, j], 60.0, 0.7, beta, 1.3) for j in range(4)], 1)
    np.testing.assert_allclose(np.array(ours), ref, rtol=0, atol=1e-12)


def test_one_euro_rejects_bad_arguments():
    with pytest.raises(ValueError, match="min_cutoff"):
        OneEuro(min_cutoff=0.0)
    with pytest.raises(TypeError, match="rate"):
        OneEuro(rate="30")


# --- the bank: its experts are the predictors they claim to be ------------------------
def test_bank_experts_equal_the_standalone_predictors():
    rng = np.random.default_rng(4)
    X = np.cumsum(np.cumsum(rng.standard_normal((120, 5)), 0), 0)
    bank = AdaptiveBank(rate=30.0)
    standalone = {
        "no motion": NoMotion(),
        "decelerating 0.2": Decelerating(0.2),
        "decelerating 0.4": Decelerating(0.4),
        "decelerating 0.6": Decelerating(0.6),
        "constant velocity": Decelerating(1.0),
        "Kalman CV": KalmanCV(),
        "One Euro": OneEuro(rate=30.0),
        "Kalman CV q/r=1e-2": KalmanCV(q=1e-2, r=1.0),
        "Kalman CV q/r=1e-4": KalmanCV(q=1e-4, r=1.0),
    }
    for x in X:
        bank.update(x)
        for p in standalone.values():
            p.update(x)
        P = bank.expert_predictions
        for name, p in standalone.items():
            np.testing.assert_allclose(P[EXPERTS.index(name)], p.predict(), rtol=1e-12, atol=1e-9)


def _fast_blend_reference(
    X, var_blocks, gamma=0.8, var_memory=30.0, max_step=10.0, first_step=None
):
    """The fast blend written plainly: every sum recomputed from the whole history.

    The block VAR's coefficients by discounted least squares on all equations so far
    (numpy's solve), the step bounds, and eq. 27's triangle fit by RVAR's exact
    ``fit_trust_weights`` on all scored frames with eq. 28's weights 2^−(T−t); until
    a scored prediction has moved, eq. 26 with α = β = ½, or `first_step` of the mean step.
    """
    from handvar.predictors.rvar import fit_trust_weights

    T, d = X.shape
    lam = 1.0 - 1.0 / var_memory
    Y = np.full((T, d), np.nan)
    Y[2:] = X[2:] - 2 * X[1:-1] + X[:-2]  # eq. 3
    out, sv_hist, cv_hist = np.empty((T, d)), [], []
    for n in range(T):  # after frame n (n + 1 frames seen)
        x, v = X[n], (X[n] - X[n - 1] if n else np.zeros(d))
        sv = x + v
        for b in var_blocks:
            k = len(b)
            ts = range(3, n + 1)  # equations (y_t, y_{t-1}), t = 3..n
            if n + 1 < 4 + k:  # fewer than k + 1 equations
                continue
            wt = np.array([lam ** (n - t) for t in ts])
            Yt, Yp = Y[list(ts)][:, b], Y[[t - 1 for t in ts]][:, b]
            D = (wt[:, None] * Yp).T @ Yp
            C = (wt[:, None] * Yt).T @ Yp
            D += 1e-9 * np.trace(D) / k * np.eye(k)
            yh = C @ np.linalg.solve(D, Y[n, b])
            ymax = np.abs(Y[n, b]).max()
            sv[b] = x[b] + np.clip(v[b] + np.clip(yh, -ymax, ymax), -max_step, max_step)
        moved = np.zeros(d, dtype=bool)
        if n == 0:
            alpha = beta = np.full(d, 0.5)
        else:
            prev = X[np.arange(n)]  # x_{t-1} for the scored frames t = 1..n
            alpha, beta = fit_trust_weights(
                X[1 : n + 1] - prev,
                np.array(sv_hist) - prev,
                np.array(cv_hist) - prev,
                0.5 ** np.arange(n - 1, -1, -1.0),
            )
            moved = (np.abs(np.array(sv_hist) - prev) + np.abs(np.array(cv_hist) - prev)).sum(0) > 0
        sv_hist.append(sv)
        cv_hist.append(x + v)
        if first_step is not None:
            alpha[~moved] = beta[~moved] = 0.5 * first_step / gamma
        else:
            alpha[~moved] = beta[~moved] = 0.5
        out[n] = x + gamma * (alpha * (sv - x) + beta * v)  # eq. 26
    return out


@pytest.mark.parametrize(
    ("var_blocks", "first_step"), [(None, None), ([[0], [1, 2, 3], [4]], None), (None, 0.0)]
)
def test_fast_blend_equals_a_plain_reference(var_blocks, first_step):
    rng = np.random.default_rng(12)
    X = np.cumsum(np.cumsum(rng.standard_normal((90, 5)), 0), 0)
    X[40:50] += 30.0 * rng.standard_normal((10, 5))  # steps beyond max_step
    X[:3, 4] = X[0, 4]  # a coordinate that starts still: its first step comes later
    bank = AdaptiveBank(var_blocks=var_blocks, first_step=first_step)
    ours = []
    for x in X:
        bank.update(x)
        ours.append(bank.expert_predictions[EXPERTS.index("fast blend")])
    blocks = [[j] for j in range(5)] if var_blocks is None else var_blocks
    want = _fast_blend_reference(X, blocks, first_step=first_step)
    np.testing.assert_allclose(np.array(ours), want, atol=1e-7)


def test_bank_weights_solve_the_simplex_least_squares():
    # After a long stationary series, the weights of one group minimise wᵀ G w on the
    # simplex for the discounted error Gram G: checked with scipy's SLSQP.
    from scipy.optimize import minimize

    rng = np.random.default_rng(5)
    X = np.cumsum(rng.standard_normal((800, 3)), 0) + 0.3 * rng.standard_normal((800, 3))
    bank = AdaptiveBank([[0, 1, 2]], memory=1e9, sweeps=50, pool=0.0, ridge=0.0)
    errors = []
    for t, x in enumerate(X):
        if t:
            errors.append(x[:, None] - bank.expert_predictions.T)  # (3, M)
        bank.update(x)
    E = np.concatenate(errors)
    G = E.T @ E / len(E)
    M = len(EXPERTS)
    res = minimize(lambda w: w @ G @ w, np.full(M, 1 / M), jac=lambda w: 2 * G @ w,
                   bounds=[(0, 1)] * M, constraints={"type": "eq", "fun": lambda w: w.sum() - 1},
                   method="SLSQP", options={"ftol": 1e-14, "maxiter": 500})  # fmt: skip
    w = bank.weights[0]
    assert w.min() >= 0 and abs(w.sum() - 1) < 1e-12
    assert w @ G @ w <= res.fun * (1 + 1e-6)


@pytest.mark.parametrize("experts", ["all", "steering"])
def test_bank_is_offset_equivariant(experts):
    rng = np.random.default_rng(6)
    X = np.cumsum(rng.standard_normal((200, 6)), 0)
    c = rng.uniform(-50, 50, 6)
    a = one_step_predictions(AdaptiveBank([[0, 1, 2], [3, 4, 5]], experts=experts), X)
    b = one_step_predictions(AdaptiveBank([[0, 1, 2], [3, 4, 5]], experts=experts), X + c)
    np.testing.assert_allclose(b[1:], a[1:] + c, rtol=0, atol=1e-9)


def test_bank_rejects_bad_input_and_resets():
    bank = AdaptiveBank()
    with pytest.raises(RuntimeError):
        bank.predict()
    bank.update([1.0, 2.0])
    with pytest.raises(ValueError, match="x: expected"):
        bank.update([1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="finite"):
        bank.update([1.0, np.nan])
    bank.reset()
    bank.update([5.0, 6.0, 7.0])  # a new series may have another size
    np.testing.assert_array_equal(bank.predict(), [5.0, 6.0, 7.0])
    with pytest.raises(ValueError, match="blocks"):
        AdaptiveBank([[0], [0, 1]]).update([1.0, 2.0])
    with pytest.raises(ValueError, match="memory"):
        AdaptiveBank(memory=0.5)
    with pytest.raises(ValueError, match="var_blocks: expected a partition"):
        AdaptiveBank(var_blocks=[[0], [0, 1]]).update([1.0, 2.0])
    with pytest.raises(ValueError, match="max_step"):
        AdaptiveBank(max_step=0.0)
    with pytest.raises(ValueError, match="first_step"):
        AdaptiveBank(first_step=1.5)
    with pytest.raises(ValueError, match="gamma"):
        AdaptiveBank(gamma=1.5)


@pytest.mark.parametrize("name", ["decelerating 0.6", "Kalman CV q/r=1e-2", "One Euro"])
def test_bank_of_one_expert_is_that_expert(name):
    rng = np.random.default_rng(8)
    X = np.cumsum(np.cumsum(rng.standard_normal((150, 4)), 0), 0)
    alone = {
        "decelerating 0.6": Decelerating(0.6),
        "Kalman CV q/r=1e-2": KalmanCV(q=1e-2, r=1.0),
        "One Euro": OneEuro(rate=30.0),
    }[name]
    bank = one_step_predictions(AdaptiveBank([[0, 1], [2, 3]], experts=[name]), X)
    np.testing.assert_allclose(bank[1:], one_step_predictions(alone, X)[1:], atol=1e-9)


def test_steering_bank_weights_only_its_experts():
    # The experts left out get no weight, and the others' weights solve the simplex
    # least squares restricted to them (checked with scipy's SLSQP as above).
    from scipy.optimize import minimize

    rng = np.random.default_rng(9)
    X = np.cumsum(np.cumsum(rng.standard_normal((800, 3)), 0), 0)
    X += 2.0 * rng.standard_normal(X.shape)
    bank = AdaptiveBank([[0, 1, 2]], memory=1e9, sweeps=50, pool=0.0, ridge=0.0,
                        experts="steering")  # fmt: skip
    keep = [EXPERTS.index(e) for e in STEERING_EXPERTS]
    errors = []
    for t, x in enumerate(X):
        if t:
            errors.append(x[:, None] - bank.expert_predictions.T[:, keep])
        bank.update(x)
    w = bank.weights[0]
    out = np.setdiff1d(np.arange(len(EXPERTS)), keep)
    assert (w[out] == 0).all() and w.min() >= 0 and abs(w.sum() - 1) < 1e-12
    E = np.concatenate(errors)
    G = E.T @ E / len(E)
    m = len(keep)
    res = minimize(lambda v: v @ G @ v, np.full(m, 1 / m), jac=lambda v: 2 * G @ v,
                   bounds=[(0, 1)] * m, constraints={"type": "eq", "fun": lambda v: v.sum() - 1},
                   method="SLSQP", options={"ftol": 1e-14, "maxiter": 500})  # fmt: skip
    assert w[keep] @ G @ w[keep] <= res.fun * (1 + 1e-6)


def test_bank_rejects_bad_experts_and_the_catalogue_steers():
    from handvar.predictors.catalogue import CATALOGUE, PredictorSpec, make_predictor

    for bad in ("some", [], ["no motion", "Kalman"], [3]):
        with pytest.raises(ValueError, match="experts: expected"):
            AdaptiveBank(experts=bad)
    assert make_predictor("bank").experts == STEERING_EXPERTS
    assert make_predictor("bank").var_blocks == hand_blocks()  # eq. 25, as RVAR's VAR
    assert make_predictor("bank-all").experts == EXPERTS
    spec = CATALOGUE["adaptive"]
    assert PredictorSpec.from_dict(spec.to_dict()).build().experts == STEERING_EXPERTS


# --- the acceptance rule: never worse than the best simple baseline -----------------
def _baseline_rmse(X, truth, resets=(), blocks=None):
    preds = league_predictors(blocks, keys=())
    out = {}
    for name in BASELINES:
        P = one_step_predictions(preds[name], X, resets=resets)
        ok = np.isfinite(P).all(1)
        out[name] = float(np.sqrt(np.mean((truth - P)[ok] ** 2)))
    return out


def _bank_rmse(X, truth, resets=(), blocks=None, experts="all", **kwargs):
    P = one_step_predictions(AdaptiveBank(blocks, experts=experts, **kwargs), X, resets=resets)
    ok = np.isfinite(P).all(1)
    return float(np.sqrt(np.mean((truth - P)[ok] ** 2)))


def _shipped_recordings():
    from handvar.synth.motion import htrack_to_handvar

    H = htrack_to_handvar(np.loadtxt(example_path("htrack")))
    D = 1000.0 * np.load(example_path("video-landmarks")).reshape(621, -1)
    clean = [
        (Recording("htrack 0-3999", H[:4000], "handvar"), hand_groups()),
        (Recording("htrack 4000-5999", H[4000:], "handvar"), hand_groups()),
        (Recording("dex", D, "keypoints"), keypoint_blocks()),
    ]
    out = []
    for rec, blocks in clean:
        out += [(r, blocks) for r in [rec, *noise_variants(rec)]]
    return out


@pytest.mark.slow
@pytest.mark.parametrize("experts", ["all", "steering"])
def test_bank_never_loses_to_the_best_baseline_on_the_shipped_recordings(experts):
    ratios = {}
    for rec, blocks in _shipped_recordings():
        truth = rec.X if rec.truth is None else rec.truth
        best = min(_baseline_rmse(rec.X, truth, blocks=blocks).values())
        ratios[rec.name] = _bank_rmse(rec.X, truth, blocks=blocks, experts=experts) / best
    assert len(ratios) == 15
    assert max(ratios.values()) <= 1.01, ratios
    assert sum(r < 1.0 for r in ratios.values()) >= len(ratios) / 2, ratios


@pytest.mark.parametrize("clip", ["fingerspelling", "counting"])
def test_both_banks_meet_the_rule_on_detected_landmarks_from_their_first_frame(clip):
    # MediaPipe's image landmarks (px) over the clip's longest run of frames with a
    # hand: short series whose hand moves fast from the start, where the second
    # prediction (the fast blend's first step) weighs in the RMSE.
    z = np.load(example_path(f"{clip}-mediapipe"))["landmarks_px"]
    X = z.reshape(len(z), -1)
    found = np.isfinite(X).all(1)
    runs = np.split(np.arange(len(X)), np.flatnonzero(np.diff(found)) + 1)
    X = X[max((r for r in runs if found[r[0]]), key=len)]
    assert len(X) > 150
    best = min(_baseline_rmse(X, X).values())
    for experts in ("steering", "all"):
        assert _bank_rmse(X, X, experts=experts) <= 1.01 * best, experts


def test_the_whole_step_experts_join_the_steering_bank_on_slow_smooth_motion():
    """The join rule (design: docs/predictors-notes.md).

    On slow smooth motion (the htrack recording slowed 4x and smoothed; a random walk in
    velocity) the constant-velocity Kalman filter is the best baseline.  The steering
    set alone, which carries at most γ = 0.8 of the step, loses to it by far; with the
    experts it keeps out joining while their error is under a quarter of its best, the
    steering bank meets the rule.
    """
    from handvar.synth.motion import htrack_to_handvar

    H = htrack_to_handvar(np.loadtxt(example_path("htrack"), max_rows=2000))
    slowed = smooth_variants(Recording("htrack 0-499", H[:500], "handvar"))[0]
    walk = smooth_variants(Recording("htrack 0-1999", H, "handvar"))[1]
    groups = hand_groups()
    for rec in (slowed, walk):  # 2000 frames each: the rule needs errors to compare
        base = _baseline_rmse(rec.X, rec.X, rec.resets)
        best = min(base.values())
        assert min(base, key=base.get) == "Kalman CV", (rec.name, base)
        alone = _bank_rmse(rec.X, rec.X, rec.resets, groups, "steering", join=0.0)
        assert alone > 1.5 * best, rec.name
        assert _bank_rmse(rec.X, rec.X, rec.resets, groups, "steering") <= 1.01 * best, rec.name
        assert _bank_rmse(rec.X, rec.X, rec.resets, groups, "all") <= 1.01 * best, rec.name


def test_no_expert_joins_the_steering_bank_on_noisy_motion():
    """On a noisy random walk no kept-out expert is ever clearly the best: their weights
    stay 0 on every frame, and the predictions are those of the bank without the rule."""
    rng = np.random.default_rng(4)
    X = np.cumsum(rng.standard_normal((400, 6)), 0) + 0.5 * rng.standard_normal((400, 6))
    bank = AdaptiveBank([[0, 1, 2], [3, 4, 5]], experts="steering")
    out = [EXPERTS.index(e) for e in EXPERTS if e not in STEERING_EXPERTS]
    for x in X:
        bank.update(x)
        assert (bank.weights[:, out] == 0).all()
    plain = AdaptiveBank([[0, 1, 2], [3, 4, 5]], experts="steering", join=0.0)
    np.testing.assert_array_equal(one_step_predictions(bank, X), one_step_predictions(plain, X))


@pytest.fixture(scope="module")
def slow_smooth_league():
    """RMSE / best baseline of both banks on the league's slow smooth rows.

    ``handvar predict htrack:0:4000 htrack:4000:6000 --layout htrack --noise --smooth``:
    each take slowed 4x and smoothed, the random walk in velocity, and their noisy copies.
    """
    from handvar.synth.motion import htrack_to_handvar

    H = htrack_to_handvar(np.loadtxt(example_path("htrack")))
    ratios = {}
    for name, X in (("0-3999", H[:4000]), ("4000-5999", H[4000:])):
        for rec in smooth_variants(Recording(name, X, "handvar")):
            for r in (rec, *noise_variants(rec)):
                truth = r.X if r.truth is None else r.truth
                best = min(_baseline_rmse(r.X, truth, r.resets).values())
                for experts in ("all", "steering"):
                    bank = _bank_rmse(r.X, truth, r.resets, hand_groups(), experts)
                    ratios[experts, r.name] = bank / best
    return ratios


@pytest.mark.slow
def test_both_banks_meet_the_rule_on_slow_smooth_motion(slow_smooth_league):
    assert len(slow_smooth_league) == 40
    assert max(slow_smooth_league.values()) <= 1.01, slow_smooth_league


def test_one_gross_error_is_not_carried_forward_by_the_autoregressions():
    """The AR experts' gate: after a slow, slightly noisy start, one outlier frame of
    50 is carried into the AR-acceleration expert's next two predictions (it enters
    x_T, v_T and y_T) without the gate, and into neither with it."""
    rng = np.random.default_rng(0)
    t = np.arange(300.0)
    x = 10.0 * np.sin(2 * np.pi * t / 400.0)
    dirty = x + 0.05 * rng.standard_normal(t.size)
    spike = 250
    dirty[spike] += 50.0

    def ar_errors(gate):
        bank = AdaptiveBank(ar_gate=gate)
        out = []
        for v in dirty:
            bank.update([v])
            out.append(bank.expert_predictions[[9, 10], 0])
        return np.abs(np.array(out)[:-1] - x[1:, None])  # against the clean next frame

    plain, gated = ar_errors(None), ar_errors(4.0)
    assert plain[spike, 1] > 100.0 and plain[spike + 1, 1] > 40.0
    assert gated[spike : spike + 3].max() < 1.5
    assert gated[spike - 20 : spike].max() < 1.0


def test_a_real_step_is_taken_one_frame_late_by_the_gate():
    """Two frames out of bounds in a row are a real change: the robust copy re-joins."""
    x = np.r_[np.zeros(100), np.full(20, 30.0)]
    bank = AdaptiveBank(ar_gate=4.0)
    for v in x[:102]:
        bank.update([v])
    assert np.allclose(bank.expert_predictions[[9, 10], 0], 30.0, atol=1e-6)


def test_the_steering_bank_ignores_the_experts_it_does_not_weight():
    """A bank's weights depend on its own experts alone: the steering bank predicts the
    same whatever the autoregressions (which it does not weight) do."""
    from handvar.synth.motion import htrack_to_handvar

    H = htrack_to_handvar(np.loadtxt(example_path("htrack"), max_rows=400))
    a = one_step_predictions(AdaptiveBank(hand_groups(), experts="steering"), H)
    b = one_step_predictions(AdaptiveBank(hand_groups(), experts="steering", ar_gate=None), H)
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("family", ["random walk", "smooth velocity", "sinusoid", "white noise"])
def test_bank_never_loses_on_synthetic_families(family):
    X = synthetic_families()[family]
    base = _baseline_rmse(X, X)
    if family == "random walk":
        assert min(base, key=base.get) == "no motion"
    if family == "smooth velocity":
        assert min(base, key=base.get) in ("Kalman CV", "decelerating 0.6")
    assert _bank_rmse(X, X) <= 1.01 * min(base.values()), base


@pytest.mark.parametrize("keep", [14, 16])
def test_bank_never_loses_on_points_layouts_from_dex(keep):
    D = 1000.0 * np.load(example_path("video-landmarks"))
    drop = {14: [3, 7, 11, 15, 19, 20, 18], 16: [7, 11, 15, 19, 20]}[keep]
    X = np.delete(D, drop, axis=1).reshape(len(D), -1)
    assert X.shape[1] == 3 * keep
    blocks = [[3 * k, 3 * k + 1, 3 * k + 2] for k in range(keep)]
    base = _baseline_rmse(X, X, blocks=blocks)
    assert _bank_rmse(X, X, blocks=blocks) <= 1.01 * min(base.values()), base


# --- the offline VAR --------------------------------------------------------------
def test_offline_var_equals_statsmodels_without_ridge():
    from statsmodels.tsa.api import VAR as SmVAR

    from handvar.synth.motion import htrack_to_handvar

    H = htrack_to_handvar(np.loadtxt(example_path("htrack"), max_rows=1500))
    X = H[:, [3, 4, 5, 14, 15, 16]]
    for order in (1, 3):
        ours = OfflineVAR(order=order, ridge=0.0).fit(X)
        ref = SmVAR(second_differences(X)).fit(order, trend="n")
        np.testing.assert_allclose(ours.coefs, ref.coefs, rtol=1e-8, atol=1e-10)
    chosen = OfflineVAR(ridge=0.0, max_order=4).fit(X)
    sel = SmVAR(second_differences(X)).select_order(4, trend="n")
    assert chosen.order_ == sel.selected_orders["bic"]


def test_offline_var_predicts_like_eq_5():
    rng = np.random.default_rng(8)
    X = np.cumsum(np.cumsum(rng.standard_normal((300, 3)), 0), 0)
    var = OfflineVAR(order=2, ridge=0.1).fit(X)
    A = var.coefs
    for x in X[:10]:
        var.update(x)
    y = second_differences(X[:10])
    expect = X[9] + (X[9] - X[8]) + A[0] @ y[-1] + A[1] @ y[-2]
    np.testing.assert_allclose(var.predict(), expect, rtol=1e-12)
    with pytest.raises(RuntimeError, match="fit"):
        OfflineVAR().update(X[0])


@pytest.mark.parametrize("gate", [None, 4.0])
def test_a_constant_column_keeps_every_prediction_finite(gate):
    """A column that never moves (a wrist-centred series' wrist) gives zero innovations:
    the gate's bound is then 0 (or undefined without a gate), never a NaN prediction."""
    rng = np.random.default_rng(1)
    X = np.c_[np.zeros(60), np.cumsum(rng.standard_normal(60))]
    P = one_step_predictions(AdaptiveBank(ar_gate=gate), X)
    assert np.isfinite(P[1:]).all()


def test_the_join_rule_does_not_act_when_the_bank_steers_the_benchmark():
    """Fed the tracker's own estimates on the benchmark, no left-out expert is ever
    clearly the best: with the join rule and without it the track is the same to the
    bit (the experiment's 50 trials: docs/predictors-notes.md)."""
    from handvar.evaluation.config import ExperimentConfig, tracker_settings
    from handvar.hand.kinematics import HandModel
    from handvar.params import hand_blocks
    from handvar.synth.sequences import make_sequence
    from handvar.tracking import Tracker

    seq = make_sequence("benchmark", n_frames=50)
    settings = tracker_settings(ExperimentConfig().tracker)
    poses = []
    for join in (None, 0.0):
        bank = AdaptiveBank(hand_groups(), experts="steering", var_blocks=hand_blocks(), join=join)
        tracker = Tracker(seq.rig, HandModel(), bank, np.random.default_rng([0, 3]), settings)
        poses.append(tracker.track(seq, seq.truth.poses[0]).poses)
        assert bank.join == (0.25 if join is None else 0.0)
    np.testing.assert_array_equal(poses[0], poses[1])
