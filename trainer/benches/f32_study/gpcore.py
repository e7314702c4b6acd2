"""GP with ARD-SE kernel, constant / fixed-OLS / GLS (vague-prior basis, R&W 2.7) / linear-kernel
prior means, on z-scored (T, V). Mirrors /work/main/trainer (normalization, bounds, starts, jitter).

Model kinds
  const      : y = (w - mean)/sd, zero-mean GP                  (trainer default, degree 0)
  fixed      : OLS polynomial (deg) on z fixed first, GP on residual/sd  (trainer --prior-degree)
  gls        : basis H marginalized (R&W eqs. 2.41-2.45), hyperparameters by REML LML (eq. 2.45)
  lin        : K + sb^2 H H^T (linear-kernel trick), ordinary LML
All models export the same firmware form:
  w(T,V) = sum_j b_j * zT^p_j * zV^q_j + sum_i a_i * exp(-1/2 sum_k (z_k/l_k - c_ik)^2)
with b in output units (deg/s), a = s_y * sf^2 * alpha'  (alpha' reported in normalized units).
"""
import numpy as np
from numpy.linalg import LinAlgError
from scipy.linalg import solve_triangular, qr
from scipy.optimize import minimize

LOG2PI = np.log(2 * np.pi)
BOUNDS = [(np.log(1e-2), np.log(1e3))] * 2 + [(np.log(1e-3), np.log(1e3)), (np.log(1e-6), np.log(10.0))]


def load(path):
    d = np.genfromtxt(path, delimiter=",", names=True)
    return np.column_stack([d["temp_c"], d["voltage_v"]]), d["rate_dps"].copy()


def plateaus(T):
    """Group labels: sorted temperatures split where the gap exceeds 1 degC."""
    order = np.argsort(T)
    lab = np.empty(len(T), int)
    g = 0
    for a, b in zip(order[:-1], order[1:]):
        lab[a] = g
        if T[b] - T[a] > 1.0:
            g += 1
    lab[order[-1]] = g
    return lab


def monos(deg):
    """(power of zT, power of zV), graded order, constant first."""
    return [(i, t - i) for t in range(deg + 1) for i in range(t, -1, -1)]


PHYS = [(i, j) for j in (0, 1, 3) for i in range(3)]  # {1,t,t^2} x {1,v,v^3}
PHYS2 = [(i, j) for j in (0, 1, 2, 3) for i in range(3)]  # {1,t,t^2} x {1,v,v^2,v^3}


def design(Z, exps):
    return np.column_stack([Z[:, 0] ** i * Z[:, 1] ** j for i, j in exps])


def chol_jitter(K):
    md = np.mean(np.diag(K))
    n = K.shape[0]
    for jit in [0.0] + [md * 10.0 ** (e - 10) for e in range(7)]:
        try:
            return np.linalg.cholesky(K + jit * np.eye(n) if jit else K), jit
        except LinAlgError:
            pass
    raise LinAlgError("not PD even with jitter")


def sqd(Z, ls):
    """Per-dimension squared scaled distances, shape (d, n, n)."""
    S = Z / ls
    return (S[:, None, :] - S[None, :, :]).transpose(2, 0, 1) ** 2


def condition(theta, Z, y, H=None, sb=None, want_grad=False, D2=None):
    """Returns dict with lml, grad (optional), Py (alpha'), beta, P-diag pieces."""
    n = len(y)
    ls = np.exp(theta[:2]); sf2 = np.exp(2 * theta[2]); sn2 = np.exp(2 * theta[3])
    if D2 is None:
        D2 = sqd(Z, ls)
    G = np.exp(-0.5 * D2.sum(0))
    K = sf2 * G + sn2 * np.eye(n)
    if sb is not None:
        K = K + sb ** 2 * H @ H.T
    L, jit = chol_jitter(K)
    # alpha-type quantities by triangular solves (not via the explicit inverse: with cond(K) ~ 1e13 the
    # explicit-inverse route put errors of up to 5e-4 deg/s into the constant-mean GP's mean)
    lo = lambda b: solve_triangular(L, b, lower=True, check_finite=False)
    up = lambda b: solve_triangular(L, b, lower=True, trans="T", check_finite=False)
    Linv = None
    logdet_half = np.log(np.diag(L)).sum()
    ys = lo(y)
    out = dict(jitter=jit)

    def Kinv():
        Li = solve_triangular(L, np.eye(n), lower=True, check_finite=False)
        return Li.T @ Li

    if H is None or sb is not None:
        Py = up(ys)
        lml = -0.5 * ys @ ys - logdet_half - 0.5 * n * LOG2PI
        Pfun = Kinv
        beta = None if sb is None else sb ** 2 * H.T @ Py
        m = 0
    else:
        Hs = lo(H)
        Q, R = qr(Hs, mode="economic", check_finite=False)
        r = ys - Q @ (Q.T @ ys)
        Py = up(r)
        m = H.shape[1]
        lml = -0.5 * r @ r - logdet_half - np.log(np.abs(np.diag(R))).sum() - 0.5 * (n - m) * LOG2PI
        beta = solve_triangular(R, Q.T @ ys, check_finite=False)

        def Pfun():
            M = up(Q)
            return Kinv() - M @ M.T
    out.update(lml=lml, alpha=Py, beta=beta, G=G, sf2=sf2, sn2=sn2, ls=ls)
    if want_grad:
        P = Pfun()
        W = np.outer(Py, Py) - P
        WK = W * (sf2 * G)
        g = np.empty(4)
        g[0] = 0.5 * np.sum(WK * D2[0])
        g[1] = 0.5 * np.sum(WK * D2[1])
        g[2] = np.sum(WK)
        g[3] = sn2 * np.trace(W)
        out["grad"] = g
        out["P"] = P
    return out


def starts(seed=0, nrand=2):
    out = [np.zeros(4), np.array([0, 0, 0, np.log(0.01)])]
    rng = np.random.default_rng(seed)
    for _ in range(nrand):
        out.append(np.concatenate([rng.uniform(-2, 3, 2), rng.uniform(-1.5, 1.5, 1), rng.uniform(-9, -2, 1)]))
    return out


def optimize(Z, y, H=None, sb=None, extra_starts=(), nrand=8, bounds=None):
    n = len(y)
    BOUNDS_ = bounds or BOUNDS

    def f(th):
        th = np.clip(th, [b[0] for b in BOUNDS_], [b[1] for b in BOUNDS_])
        try:
            c = condition(th, Z, y, H, sb, want_grad=True)
        except LinAlgError:
            return 1e10, np.zeros(4)
        return -c["lml"] / n, -c["grad"] / n

    best = None
    for s in list(starts(nrand=nrand)) + list(extra_starts):
        s = np.clip(s, [b[0] for b in BOUNDS_], [b[1] for b in BOUNDS_])
        try:
            r = minimize(f, s, jac=True, method="L-BFGS-B", bounds=BOUNDS_,
                         options=dict(maxiter=300, ftol=1e-12, gtol=1e-7))
        except Exception:
            continue
        if np.isfinite(r.fun) and (best is None or r.fun < best.fun):
            best = r
    return best.x


class Model:
    """kind in {const, fixed, gls, lin}; exps: basis exponents (ignored for const)."""

    def __init__(self, kind, exps=None, sb=None, yscale="resid", bounds=None):
        self.kind, self.exps, self.sb, self.yscale, self.bounds = kind, exps, sb, yscale, bounds

    def prepare(self, X, w):
        self.off = X.mean(0); self.scl = X.std(0)
        Z = (X - self.off) / self.scl
        self.Z = Z
        if self.kind in ("const", "fixed"):
            ex = [(0, 0)] if self.kind == "const" else self.exps
            Hf = design(Z, ex)
            c = np.linalg.lstsq(Hf, w, rcond=None)[0]
            res = w - Hf @ c
            self.fixed_c = c; self.fixed_exps = ex
            self.ym = res.mean(); self.ys = res.std()
            y = res / self.ys
            H = None
        else:
            # y = (w - H c0) / s. Subtracting H c0 (any c0) only shifts beta-hat, so the GLS fit is
            # unchanged except through the hyperparameter bounds, which are relative to s.
            H = design(Z, self.exps)
            if self.yscale == "resid":  # c0 = OLS fit, s = std of the OLS residual
                c0 = np.linalg.lstsq(H, w, rcond=None)[0]
                res = w - H @ c0
                self.ys = res.std()
            else:  # "total": c0 = mean, s = std of w (the brief's 'normalized y')
                c0 = np.zeros(H.shape[1]); c0[self.exps.index((0, 0))] = w.mean()
                self.ys = w.std()
            self.c0 = c0; self.ym = 0.0
            y = (w - H @ c0) / self.ys
        self.y, self.H = y, H
        return Z, y, H

    def fit(self, X, w, theta=None, extra_starts=()):
        Z, y, H = self.prepare(X, w)
        if theta is None:
            theta = optimize(Z, y, H, self.sb, extra_starts, bounds=self.bounds)
        self.theta = theta
        c = condition(theta, Z, y, H, self.sb)
        self.lml, self.alpha, self.jitter = c["lml"], c["alpha"], c["jitter"]
        self.ls, self.sf2 = c["ls"], c["sf2"]
        self.beta = c["beta"]
        self._export()
        return self

    def _export(self):
        """Firmware form: b over exps (output units), a_i, centres c = Z/l."""
        if self.kind in ("const", "fixed"):
            exps = list(self.fixed_exps)
            b = self.fixed_c.copy()
            # ym is ~0 (OLS residual has zero mean when the basis has a constant); fold it in anyway
            b[exps.index((0, 0))] += self.ym
        else:
            exps = list(self.exps)
            b = self.c0 + self.ys * self.beta
        self.fw = dict(off=self.off, scl=self.scl, inv_ls=1.0 / self.ls, cen=self.Z / self.ls,
                       a=self.ys * self.sf2 * self.alpha, exps=exps, b=b)

    def predict(self, X):
        fw = self.fw
        Z = (X - fw["off"]) / fw["scl"]
        U = Z * fw["inv_ls"]
        d2 = ((U[:, None, :] - fw["cen"][None, :, :]) ** 2).sum(-1)
        return design(Z, fw["exps"]) @ fw["b"] + np.exp(-0.5 * d2) @ fw["a"]

    # ---------- leave-one-out ----------
    def loo_closed(self):
        c = condition(self.theta, self.Z, self.y, self.H, self.sb, want_grad=True)
        P = c["P"]
        return -c["alpha"] / np.diag(P) * self.ys  # prediction - target, deg/s

    def loo_brute(self):
        n = len(self.y)
        err = np.empty(n)
        Z, y, H = self.Z, self.y, self.H
        for i in range(n):
            k = np.arange(n) != i
            Hk = None if H is None else H[k]
            c = condition(self.theta, Z[k], y[k], Hk, self.sb)
            ks = c["sf2"] * np.exp(-0.5 * (((Z[i] - Z[k]) / c["ls"]) ** 2).sum(1))
            mu = ks @ c["alpha"]
            if H is not None:
                mu += H[i] @ c["beta"] if self.sb is None else H[i] @ c["beta"]
            err[i] = (mu - y[i]) * self.ys
        return err


def _fma(a, b, c):
    """f32 fused multiply-add, emulated: a*b of two f32 is exact in f64 (48 bits)."""
    return (a.astype(np.float64) * np.float64(b) + c.astype(np.float64)).astype(np.float32)


def split_lin(fw):
    """Move the dominant term b_(0,1) * zV into raw-V form D*V (zV = (V-o)/s): returns the remainder
    coefficients b' (same exponents, (0,1) zeroed, constant adjusted) and D = b_(0,1)/s in f64."""
    b = fw["b"].copy(); e = fw["exps"]
    if (0, 1) not in e:
        return b, 0.0
    jv = e.index((0, 1)); j0 = e.index((0, 0))
    D = b[jv] / fw["scl"][1]
    b[j0] -= D * fw["off"][1]
    b[jv] = 0.0
    return b, D


def eval_f32(fw, X, scheme="plain", part="all"):
    """Firmware evaluation in float32 (every array op below rounds to f32). X: f32-representable.
    scheme: plain  - kernel terms then polynomial terms (highest degree first), one f32 accumulator
            kahan  - same terms through one Kahan-compensated f32 accumulator
            rawv   - dominant zV term rewritten as D*V on the raw (exact) input, added last; rest plain
            comp   - as rawv, D stored as f32 hi+lo and V*D_hi split exactly with an FMA (TwoProduct),
                     everything else plain f32; the only large rounding is the final add
    part: all | kernel (kernel sum only) | poly (polynomial only)."""
    f = np.float32
    X = X.astype(f)
    V = X[:, 1]
    off = fw["off"].astype(f); scl = fw["scl"].astype(f); inv_ls = fw["inv_ls"].astype(f)
    cen = fw["cen"].astype(f); a = fw["a"].astype(f)
    if scheme in ("rawv", "comp"):
        b64, D = split_lin(fw)
    else:
        b64, D = fw["b"], 0.0
    b = b64.astype(f)
    z0 = (X[:, 0] - off[0]) / scl[0]
    z1 = (V - off[1]) / scl[1]
    u0 = z0 * inv_ls[0]; u1 = z1 * inv_ls[1]
    half = f(0.5)
    maxp = max(max(e) for e in fw["exps"])
    p0 = [np.ones_like(z0)]; p1 = [np.ones_like(z1)]
    for _ in range(maxp):
        p0.append(p0[-1] * z0); p1.append(p1[-1] * z1)
    acc = np.zeros_like(z0); comp = np.zeros_like(z0)

    def add(t):
        nonlocal acc, comp
        if scheme == "kahan":
            yy = t - comp
            tt = acc + yy
            comp = (tt - acc) - yy
            acc = tt
        else:
            acc = acc + t

    if part in ("all", "kernel"):
        for i in range(len(a)):
            d0 = u0 - cen[i, 0]; d1 = u1 - cen[i, 1]
            k = np.exp(-half * (d0 * d0 + d1 * d1))
            add(a[i] * k)
    if part in ("all", "poly"):
        for j in reversed(range(len(fw["exps"]))):
            i, k = fw["exps"][j]
            if b[j] != 0:
                add(b[j] * (p0[i] * p1[k]))
        if scheme == "rawv":
            acc = acc + f(D) * V
        elif scheme == "comp":
            Dhi = f(D); Dlo = f(D - np.float64(Dhi))
            p = Dhi * V
            e = _fma(V, Dhi, -p)          # exact: V*Dhi = p + e
            acc = acc + (e + Dlo * V)
            acc = acc + p
    assert acc.dtype == f
    return acc.astype(np.float64)


def predict_parts(fw, X):
    Z = (X - fw["off"]) / fw["scl"]
    U = Z * fw["inv_ls"]
    d2 = ((U[:, None, :] - fw["cen"][None, :, :]) ** 2).sum(-1)
    return np.exp(-0.5 * d2) @ fw["a"], design(Z, fw["exps"]) @ fw["b"]


def grid(X, n=60):
    T = np.linspace(X[:, 0].min(), X[:, 0].max(), n)
    V = np.linspace(X[:, 1].min(), X[:, 1].max(), n)
    TT, VV = np.meshgrid(T, V)
    G = np.column_stack([TT.ravel(), VV.ravel()])
    return G.astype(np.float32).astype(np.float64)  # f32-representable inputs: the f64 reference sees the same input


class HybridModel(Model):
    """Hyperparameters from the constant-mean GP (ordinary LML, y = (w-mean)/sd), then the GLS mean
    with basis `exps` at those fixed hyperparameters (same y scaling, so theta transfers as is)."""

    def __init__(self, exps):
        super().__init__("gls", exps, yscale="total")

    def fit(self, X, w, theta=None, extra_starts=()):
        if theta is None:
            theta = Model("const").fit(X, w).theta
        return super().fit(X, w, theta=theta)


# Tighter bounds for the GLS residual GP (resid units): l >= 0.1 (below the spacing of the rate levels the
# "independent level" mode appears), sigma_f <= 10 (beyond it the GP and the basis trade off along a ridge).
BOUNDS_TIGHT = [(np.log(0.1), np.log(1e3))] * 2 + [(np.log(1e-3), np.log(10.0)), (np.log(1e-6), np.log(10.0))]
