"""Candidate 'cheb': distil the constant-mean GP's f64 mean into firmware form
   w(T,V) = D*V + sum_ij C_ij T_i(t) T_j(v)   (tensor Chebyshev on the trained rectangle),
D = OLS slope of the data on V (stored as f32 hi+lo, V*D_hi split exactly by an FMA).
Accuracy (LOO/LOTO) is the constant-mean GP's plus the distillation error, reported separately."""
import numpy as np
from numpy.polynomial import chebyshev as C
from gpcore import _fma


def cheb_nodes(n):
    return np.cos(np.pi * (np.arange(n) + 0.5) / n)


def distil(predict, X, w, nT, nV, rect=None):
    lo, hi = rect if rect is not None else (X.min(0), X.max(0))
    mid = (hi + lo) / 2; half = (hi - lo) / 2
    D = np.linalg.lstsq(np.column_stack([np.ones(len(w)), X[:, 1]]), w, rcond=None)[0][1]
    tn, vn = cheb_nodes(nT), cheb_nodes(nV)
    TT, VV = np.meshgrid(mid[0] + half[0] * tn, mid[1] + half[1] * vn, indexing="ij")
    P = np.column_stack([TT.ravel(), VV.ravel()])
    r = (predict(P) - D * P[:, 1]).reshape(nT, nV)
    # interpolation at first-kind nodes: C = (2/n) T(nodes)^T r ... via least squares (exact interpolation)
    A = C.chebvander(tn, nT - 1); B = C.chebvander(vn, nV - 1)
    Cf = np.linalg.solve(A, np.linalg.solve(B, r.T).T)
    return dict(mid=mid, inv_half=1.0 / half, D=D, C=Cf)


def eval64(cm, X):
    t = (X[:, 0] - cm["mid"][0]) * cm["inv_half"][0]
    v = (X[:, 1] - cm["mid"][1]) * cm["inv_half"][1]
    return C.chebval2d(t, v, cm["C"]) + cm["D"] * X[:, 1]


def _clenshaw32(x, coefs):
    """coefs: list of f32 arrays/scalars c_0..c_n; returns sum c_k T_k(x) in f32."""
    f = np.float32
    b1 = np.zeros_like(x); b2 = np.zeros_like(x)
    two_x = f(2) * x
    for c in reversed(coefs[1:]):
        b1, b2 = two_x * b1 - b2 + c, b1
    return x * b1 - b2 + coefs[0]


def eval32(cm, X, comp=True):
    f = np.float32
    X = X.astype(f)
    mid = cm["mid"].astype(f); ih = cm["inv_half"].astype(f); Cf = cm["C"].astype(f)
    t = (X[:, 0] - mid[0]) * ih[0]
    v = (X[:, 1] - mid[1]) * ih[1]
    ci = [_clenshaw32(v, list(Cf[i])) for i in range(Cf.shape[0])]  # c_i(v)
    r = _clenshaw32(t, ci)
    V = X[:, 1]
    if comp:
        Dhi = f(cm["D"]); Dlo = f(cm["D"] - np.float64(Dhi))
        p = Dhi * V
        e = _fma(V, Dhi, -p)
        out = (r + (e + Dlo * V)) + p
    else:
        out = r + f(cm["D"]) * V
    assert out.dtype == f
    return out.astype(np.float64)


DEGREES = [(8, 16), (10, 20), (12, 24), (14, 28), (16, 32), (20, 40), (24, 48)]


def distil_auto(predict, X, w, check, tol=1e-6, rect=None):
    """Smallest tensor size in DEGREES whose max |cheb - GP| on the `check` points is below tol."""
    ref = predict(check)
    for nT, nV in DEGREES:
        cm = distil(predict, X, w, nT, nV, rect)
        err = float(np.abs(eval64(cm, check) - ref).max())
        if err < tol:
            break
    cm.update(nT=nT, nV=nV, distil_err=err)
    return cm
