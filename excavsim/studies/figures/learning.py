"""The force-learning figures of Singh 1995 §5.2.3-5.2.4 (Figs. 68-80) by ``excavsim figures``.

Figs. 68-73 are the thesis' one-dimensional example: eq. 18, ``y = 3 sin x + 4 cos 0.2x + (0.02x)^2``,
plus Gaussian noise of variance 1, with the data in ``4 < x < 6`` removed. The thesis gives no
range of x nor the number of points: we take 200 points uniform over [0, 10] (assumed), and the
kernel widths K_w of eq. 24 in units of that range (K_w = 2^-6 is then 0.16 in x, 2^-3 is 1.25,
which reproduces "affected by noise" and "too smooth"). The fits are this project's: global
regression by least squares (eq. 19), the mean of the three nearest neighbours, locally weighted
linear regression with eq. 24's Gaussian weights, and a one-hidden-layer net
(:class:`~excavsim.learning.net.NeuralNet`).

Figs. 71 and 74-80 use force data: the 12 simulated digs of ``tests/data/learning_digs.npz``
(made by :mod:`excavsim.learning.collect` in the testbed sand, seed 1; 1145 samples). Fig. 75's two
exemplar digs are two of them, held out; every model of Figs. 76-80 is trained on the other ten
(the thesis trained on ~4000 samples of 30 digs).
"""

from __future__ import annotations

import functools
import math
import pathlib
import time

import numpy as np

from excavsim import constants
from excavsim.config import get_soil
from excavsim.learning.dataset import ForceDataset
from excavsim.learning.evaluate import magnitude
from excavsim.learning.memory import LocallyWeightedRegression
from excavsim.learning.net import NeuralNet
from excavsim.learning.predictors import WedgeModel, make_model
from excavsim.planning.figures import _figure, _save

X_RANGE = (0.0, 10.0)  # assumed: the thesis does not give it
N_POINTS = 200  # assumed
GAP = (4.0, 6.0)  # eq. 18's removed data (§5.2.3)
FORCE_DATA = constants.REPO_ROOT / "tests" / "data" / "learning_digs.npz"
EXEMPLARS = (3, 9)  # the two held-out digs of Figs. 75-80


def eq18(x: np.ndarray) -> np.ndarray:
    """Eq. 18: the one-dimensional example's underlying function."""
    return 3 * np.sin(x) + 4 * np.cos(0.2 * x) + (0.02 * x) ** 2


def example_data(seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Fig. 68's data set: eq. 18 plus unit Gaussian noise on [0, 10], without 4 < x < 6."""
    rng = np.random.default_rng(seed)
    x = np.sort(rng.uniform(*X_RANGE, N_POINTS))
    x = x[(x <= GAP[0]) | (x >= GAP[1])]
    return x, eq18(x) + rng.normal(0.0, 1.0, x.size)


BASES_1D = {
    "linear (eq. 20)": lambda x: np.column_stack([x, np.ones_like(x)]),
    "approximate (eq. 21)": lambda x: np.column_stack([np.sin(x), np.cos(x), x ** 2, np.ones_like(x)]),
    "exact (eq. 18)": lambda x: np.column_stack([np.sin(x), np.cos(0.2 * x), x ** 2]),
}


def global_fit(x, y, xq, basis) -> np.ndarray:
    """Eq. 19 on ``basis``."""
    k, *_ = np.linalg.lstsq(basis(x), y, rcond=None)
    return basis(xq) @ k


def nearest_mean(x, y, xq, k: int = 3) -> np.ndarray:
    """The mean of the ``k`` nearest samples."""
    idx = np.argsort(np.abs(xq[:, None] - x[None, :]), axis=1)[:, :k]
    return y[idx].mean(axis=1)


def lwr_1d(x, y, xq, width: float, basis=None) -> np.ndarray:
    """Locally weighted regression (eqs. 23-24): a local linear model in x (or on ``basis``) per query,
    Gaussian weights with kernel width ``width`` in units of the x range."""
    span = X_RANGE[1] - X_RANGE[0]
    out = np.empty(xq.size)
    for i, q in enumerate(xq):
        w = np.exp(-((x - q) / span) ** 2 / (2 * width ** 2))
        g = np.column_stack([np.ones_like(x), x - q]) if basis is None else basis(x)
        sw = np.sqrt(w / w.max())
        k, *_ = np.linalg.lstsq(g * sw[:, None], y * sw, rcond=1e-10)
        out[i] = k[0] if basis is None else (basis(np.array([q])) @ k)[0]
    return out


def net_fit(x, y, xq, hidden: int, basis=None, seed: int = 0, starts: int = 5) -> np.ndarray:
    """A one-hidden-layer net on x (or on ``basis``'s functions), the best of ``starts`` initial weights
    by training error (a small net trained on 160 points often stops in a poor local minimum: the
    thesis' "black art", §5.2.3.3)."""
    f = (lambda v: v[:, None]) if basis is None else (lambda v: basis(v)[:, :3])
    best, best_err = None, np.inf
    for s in range(starts):
        net = NeuralNet("naive", hidden=hidden, max_iter=5000, alpha=1e-3, seed=seed * starts + s)
        net.fit_inputs(f(x), np.column_stack([y, y]))
        err = float(np.mean((net.predict_inputs(f(x))[:, 0] - y) ** 2))
        if err < best_err:
            best, best_err = net, err
    return best.predict_inputs(f(xq))[:, 0]


def _panels(ctx, path, title, fits, *, cols=None):
    x, y = example_data(ctx.seed)
    xq = np.linspace(*X_RANGE, 400)
    n = len(fits)
    cols = cols or min(n, 2)
    rows = math.ceil(n / cols)
    fig = _figure((5.0 * cols, 3.4 * rows))
    errs = []
    for i, (label, fn) in enumerate(fits):
        ax = fig.add_subplot(rows, cols, i + 1)
        yq = fn(x, y, xq)
        ax.plot(x, y, ".", color="#999999", ms=3)
        ax.plot(xq, eq18(xq), "k:", lw=0.8)
        ax.plot(xq, yq, "C0-", lw=1.5)
        ax.axvspan(*GAP, color="C3", alpha=0.08)
        rms = float(np.sqrt(np.mean((yq - eq18(xq)) ** 2)))
        gap = (xq > GAP[0]) & (xq < GAP[1])
        rms_gap = float(np.sqrt(np.mean((yq[gap] - eq18(xq[gap])) ** 2)))
        errs.append((label, rms, rms_gap))
        ax.set_title(f"({chr(97 + i)}) {label}: RMS {rms:.2f}, in the gap {rms_gap:.2f}", fontsize=8)
        ax.set_xlabel("x")
        ax.set_ylabel("y")
    fig.suptitle(title, fontsize=10)
    _save(fig, path)
    return "; ".join(f"{label}: RMS {r:.2f} ({g:.2f} in the gap)" for label, r, g in errs)


def fig68(ctx, path: pathlib.Path) -> str:
    """Fig. 68: eq. 18 with unit Gaussian noise, the data in 4 < x < 6 removed."""
    x, y = example_data(ctx.seed)
    xq = np.linspace(*X_RANGE, 400)
    fig = _figure((7.0, 3.6))
    ax = fig.add_subplot()
    ax.plot(x, y, ".", color="C0", ms=4, label=f"{x.size} noisy samples")
    ax.plot(xq, eq18(xq), "k-", lw=1.0, label="eq. 18")
    ax.axvspan(*GAP, color="C3", alpha=0.08, label="removed")
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.legend(fontsize=7)
    ax.set_title("Fig. 68: a one-dimensional example (eq. 18, noise of variance 1, data removed)", fontsize=9)
    _save(fig, path)
    return f"{x.size} samples on [0, 10] without (4, 6); noise std {float(np.std(y - eq18(x))):.2f}"


def fig69(ctx, path):
    """Fig. 69: global regression with linear, approximate and exact bases."""
    return _panels(ctx, path, "Fig. 69: global regression (eq. 19)",
                   [(name, functools.partial(global_fit, basis=b)) for name, b in BASES_1D.items()], cols=3)


def fig70(ctx, path):
    """Fig. 70: memory-based fits: 3 nearest neighbours, LWR narrow and wide, wide on eq. 21's basis."""
    approx = BASES_1D["approximate (eq. 21)"]
    return _panels(ctx, path, "Fig. 70: memory-based methods", [
        ("3 nearest neighbours averaged", nearest_mean),
        ("LWR, K_w = 2^-6", functools.partial(lwr_1d, width=2.0 ** -6)),
        ("LWR, K_w = 2^-3", functools.partial(lwr_1d, width=2.0 ** -3)),
        ("LWR, K_w = 2^-3, eq. 21 basis", functools.partial(lwr_1d, width=2.0 ** -3, basis=approx)),
    ])


def fig72(ctx, path):
    """Fig. 72: a net of 10 and of 50 hidden units on x alone."""
    return _panels(ctx, path, "Fig. 72: one hidden layer on x alone", [
        ("10 hidden units", functools.partial(net_fit, hidden=10, seed=ctx.seed)),
        ("50 hidden units", functools.partial(net_fit, hidden=50, seed=ctx.seed)),
    ])


def fig73(ctx, path):
    """Fig. 73: a net of 5 hidden units on eq. 21's basis."""
    approx = BASES_1D["approximate (eq. 21)"]
    return _panels(ctx, path, "Fig. 73: 5 hidden units on the basis of eq. 21", [
        ("5 hidden units, eq. 21 basis", functools.partial(net_fit, hidden=5, basis=approx, seed=ctx.seed))], cols=1)


@functools.lru_cache(maxsize=1)
def force_data() -> ForceDataset:
    """The force data of Figs. 71, 74-80 (see the module docstring)."""
    return ForceDataset.load(FORCE_DATA)


def fig71(ctx, path):
    """Fig. 71: LWR's prediction time against the number of inputs, and time and error against the
    fraction of the force data used."""
    rng = np.random.default_rng(ctx.seed)
    dims = [1, 2, 4, 6, 8, 10, 12, 16]
    t_dim = []
    for d in dims:
        x = rng.uniform(size=(3000, d))
        y = np.column_stack([np.sin(4 * x).sum(axis=1)] * 2)
        m = LocallyWeightedRegression("naive", width=0.3).fit_inputs(x, y)
        q = rng.uniform(size=(200, d))
        t0 = time.perf_counter()
        m.predict_inputs(q)
        t_dim.append((time.perf_counter() - t0) / len(q))
    data = force_data()
    fx = data.forces
    test = np.isin(data["dig"], EXEMPLARS)
    train_all = np.nonzero(~test)[0]
    fracs = [0.1, 0.2, 0.4, 0.6, 0.8, 1.0]
    t_frac, e_frac = [], []
    for f in fracs:
        idx = rng.choice(train_all, max(int(f * train_all.size), 50), replace=False)
        m = make_model("lwr", "mechanics", seed=ctx.seed)
        m.fit(data.subset(idx).samples, fx[idx])
        t0 = time.perf_counter()
        pred = m.predict(data.subset(np.nonzero(test)[0]).samples)
        t_frac.append((time.perf_counter() - t0) / int(test.sum()))
        e_frac.append(float(np.mean(np.abs(magnitude(pred) - magnitude(fx[test])))))
    fig = _figure((10.0, 3.8))
    ax = fig.add_subplot(1, 2, 1)
    ax.plot(dims, 1e3 * np.array(t_dim), "o-")
    ax.set_xlabel("input variables D")
    ax.set_ylabel("prediction time per query [ms]")
    ax.set_title("(a) LWR, 3000 points", fontsize=9)
    ax = fig.add_subplot(1, 2, 2)
    ax.plot(fracs, 1e3 * np.array(t_frac), "o-", color="C0")
    ax.set_xlabel(f"fraction of the {train_all.size} training samples used")
    ax.set_ylabel("time per query [ms]", color="C0")
    ax2 = ax.twinx()
    ax2.plot(fracs, e_frac, "s--", color="C3")
    ax2.set_ylabel("mean |F| error on the two exemplar digs [N]", color="C3")
    ax.set_title("(b) force data, random subsets", fontsize=9)
    fig.suptitle("Fig. 71: prediction time of locally weighted regression", fontsize=10)
    _save(fig, path)
    return (f"time per query {1e3 * t_dim[0]:.2f} ms at D=1 to {1e3 * t_dim[-1]:.2f} ms at D={dims[-1]}; "
            f"error {e_frac[0]:.0f} N with 10 % of the data, {e_frac[-1]:.0f} N with all")


def fig74(ctx, path):
    """Fig. 74: mean error of F_x against the number of hidden units (held-out digs)."""
    data = force_data()
    y = data.forces
    digs = np.unique(data["dig"])
    units = [2, 5, 10, 20, 30, 40, 60]
    errs = []
    for h in units:
        e = []
        for fold in np.array_split(digs, 4):
            test = np.isin(data["dig"], fold)
            net = NeuralNet("mechanics", hidden=h, seed=ctx.seed)
            net.fit(data.subset(np.nonzero(~test)[0]).samples, y[~test])
            pred = net.predict(data.subset(np.nonzero(test)[0]).samples)
            e.append(np.abs(pred[:, 0] - y[test, 0]))
        errs.append(float(np.mean(np.concatenate(e))))
    fig = _figure((6.0, 3.8))
    ax = fig.add_subplot()
    ax.plot(units, errs, "o-")
    ax.set_xlabel("hidden units")
    ax.set_ylabel("mean |F_x| error, held-out digs [N]")
    ax.set_title("Fig. 74: error in F_x against hidden units (4-fold by dig)", fontsize=9)
    _save(fig, path)
    best = units[int(np.argmin(errs))]
    return "F_x error by hidden units: " + ", ".join(f"{h}: {e:.0f} N" for h, e in zip(units, errs)) + \
        f"; lowest at {best}"


def _exemplar_predictions(ctx) -> dict:
    key = ("exemplars", ctx.seed)
    if key in ctx.cache:
        return ctx.cache[key]
    data = force_data()
    y = data.forces
    test = np.isin(data["dig"], EXEMPLARS)
    train = data.subset(np.nonzero(~test)[0])
    soil = get_soil(data.meta.get("soil", "testbed_sand"))
    width = float(data.meta.get("bucket_width_m", 0.3))
    models = {
        "fig76": ("wedge model, fitted parameters", WedgeModel(soil, width, seed=ctx.seed)),
        "fig77": ("global regression, mechanics basis", make_model("global", "mechanics", seed=ctx.seed)),
        "fig78": ("LWR, mechanics basis", make_model("lwr", "mechanics", seed=ctx.seed)),
        "fig79": ("LWR scaled by importance, mechanics basis", make_model("lwr_scaled", "mechanics", seed=ctx.seed)),
        "fig80": ("back propagation, 30 hidden units, mechanics basis", NeuralNet("mechanics", hidden=30,
                                                                                  seed=ctx.seed)),
    }
    out = {}
    for name, (label, model) in models.items():
        model.fit(train.samples, y[~test])
        out[name] = (label, model.predict(data.subset(np.nonzero(test)[0]).samples))
    ctx.cache[key] = (out, test)
    return ctx.cache[key]


def fig75(ctx, path):
    """Fig. 75: the two exemplar digs: their paths and measured forces."""
    data = force_data()
    fig = _figure((10.0, 3.8))
    parts = []
    for i, dig in enumerate(EXEMPLARS):
        sel = data["dig"] == dig
        ax = fig.add_subplot(1, 2, i + 1)
        ax.plot(data["x"][sel], data["z"][sel], "k-", lw=1.0, label="tip path")
        ax.set_xlabel("x [m]")
        ax.set_ylabel("z [m]")
        ax2 = ax.twinx()
        ax2.plot(data["x"][sel], magnitude(data.forces[sel]), "C0.", ms=3, label="|F| measured")
        ax2.set_ylabel("|F| [N]", color="C0")
        k, a = float(data["k"][sel][0]), math.degrees(float(data["alpha"][sel][0]))
        ax.set_title(f"dig {dig}: k {k:.2f} m, alpha {a:.0f} deg, {int(sel.sum())} samples", fontsize=9)
        parts.append(f"dig {dig}: k {k:.2f} m, alpha {a:.0f} deg, peak |F| {magnitude(data.forces[sel]).max():.0f} N")
    fig.suptitle("Fig. 75: two exemplar digs (held out of the training data of Figs. 76-80)", fontsize=10)
    _save(fig, path)
    return "; ".join(parts)


def _prediction_figure(name: str, number: int):
    def draw(ctx, path):
        preds, test = _exemplar_predictions(ctx)
        label, pred = preds[name]
        data = force_data()
        y = data.forces[test]
        digs = data["dig"][test]
        t = data["t"][test]
        fig = _figure((10.0, 6.0))
        for i, dig in enumerate(EXEMPLARS):
            sel = digs == dig
            for j, comp in enumerate(("F_x", "F_z")):
                ax = fig.add_subplot(2, 2, 2 * j + i + 1)
                ax.plot(t[sel] - t[sel][0], y[sel, j], "o", ms=2.5, mfc="none", color="k", label="measured")
                ax.plot(t[sel] - t[sel][0], pred[sel, j], "C0-", lw=1.4, label="predicted")
                ax.set_ylabel(f"{comp} [N]")
                if j == 1:
                    ax.set_xlabel("time into the dig [s]")
                if j == 0:
                    ax.set_title(f"dig {dig}", fontsize=9)
                if i == j == 0:
                    ax.legend(fontsize=7)
        fig.suptitle(f"Fig. {number}: prediction of the resistive forces: {label}", fontsize=10)
        _save(fig, path)
        mae = float(np.mean(np.abs(magnitude(pred) - magnitude(y))))
        return f"{label}: mean |F| error {mae:.0f} N on the two held-out digs ({int(test.sum())} samples)"

    draw.__doc__ = f"Fig. {number}: predictions on the two exemplar digs."
    return draw


fig76 = _prediction_figure("fig76", 76)
fig77 = _prediction_figure("fig77", 77)
fig78 = _prediction_figure("fig78", 78)
fig79 = _prediction_figure("fig79", 79)
fig80 = _prediction_figure("fig80", 80)
