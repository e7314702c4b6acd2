"""Prints the markdown tables from results/*.json."""
import glob, json, sys
import numpy as np
FILES = ["nominal", "101", "102", "103", "104", "105"]
R = {}
for p in glob.glob("results/*.json"):
    r = json.load(open(p)); R[(r["cand"], r["file"])] = r
order = [c for c in ["const", "fixed3", "gls1", "gls2", "gls3", "gls3t", "gls3b", "lin3t", "phys", "physb", "cheb"]
         if any((c, f) in R for f in FILES)]
g = lambda x: "–" if x is None or (isinstance(x, float) and np.isnan(x)) else f"{x:.2g}"
print("| cand | unit | LOO °/s | worst LOTO °/s (T) | max|α'| | max|a| °/s | f32 plain / Kahan | f32 raw-V / FMA-comp | hyper (ℓT, ℓV, σf, σn) |")
print("|---|---|---|---|---|---|---|---|---|")
for c in order:
    for f in FILES:
        r = R.get((c, f))
        if not r: continue
        f32 = r["f32"]
        extra = f" (cheb {r['nT']}×{r['nV']}, distil {r['distil_err']:.0e})" if c == "cheb" else ""
        print(f"| {c} | {f} | {r['loo_closed']:.3g} | {r['loto_worst']:.3g} ({r['loto_worst_T']:.0f}) | {g(r['max_alpha'])} | {g(r['max_a_dps'])} "
              f"| {f32['plain']:.2g} / {g(f32['kahan'])} | {f32['rawv']:.2g} / {f32['comp']:.2g} | "
              + ", ".join(f"{h:.3g}" for h in r["hyper"]) + extra + " |")
print()
print("Ratios to the constant-mean GP (LOO / worst LOTO), pass = both ≤ 1.2 and FMA-comp f32 ≤ 1e-5:")
print("| cand | " + " | ".join(FILES) + " | all pass |")
print("|---|" + "---|" * (len(FILES) + 1))
for c in order:
    cells = []; ok = True
    for f in FILES:
        r, b = R.get((c, f)), R.get(("const", f))
        if not r or not b: cells.append("–"); ok = False; continue
        a1, a2 = r["loo_closed"] / b["loo_closed"], r["loto_worst"] / b["loto_worst"]
        p = a1 <= 1.2 and a2 <= 1.2 and r["f32"]["comp"] <= 1e-5
        ok &= p
        cells.append(f"{a1:.2f} / {a2:.2f}{'' if p else ' ✗'}")
    print(f"| {c} | " + " | ".join(cells) + f" | {'yes' if ok else 'no'} |")
print()
print("f32 floor (|round_f32(f64) - f64|, max over grid):", ", ".join(f"{f} {R[('const', f)]['f32_floor']:.1e}" for f in FILES if ('const', f) in R))
