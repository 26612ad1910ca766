"""Figures of ``remote-trigger paper`` (PNG, matplotlib Agg), made from the files.

Every function reads the HDF5 / dump files of an output folder written by
:mod:`remote_trigger.pywrap.jobs.paper` and writes one PNG; :func:`make_all`
writes all of them. Units are LAMMPS ``lj`` units (docs/model.md section 1):
length sigma = 2 R1, mass m, time tau (the lj time; with k_n = 2e5 in
force / length^1.5 the contact frequencies are ~ 10 - 200 / tau), force
in lj force units; eigenvalues of M^-1 K in 1/tau^2, velocities in
sigma/tau, D in sigma^2.

=============================  =================================================
``fig1_packing.png``           the relaxed packing (paper Fig. 1)
``fig2_mu_law.png``            mu(v) of Eq. 4 (paper Fig. 2)
``fig3_eigenvalues.png``       the coalescing pair vs F_x, both mu (Fig. 3)
``fig4_msd.png``               D(t) above F_x^c with the predicted rate (Fig. 4)
``fig5_perturb.png``           runs (a)-(d), (p) and mu(v(t)) (Fig. 5)
``fig_normal_form.png``        A vs eps for several tau (normal form, Sec. IV)
=============================  =================================================
"""
import os

import numpy as np

from remote_trigger.pywrap.jobs.paper import report as rep
from remote_trigger.analysis.output import savefig_atomic

#: axis labels with units (lj: sigma = 2 R1, tau = lj time)
T_LABEL = r"time $t$ [$\tau$]"
F_LABEL = r"$F_x$ per top disk [lj force]"
D_LABEL = r"MSD $D(t)$ [$\sigma^2$]"
V_LABEL = r"[$\sigma/\tau$]"


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path):
    savefig_atomic(fig, path, dpi=120)
    _plt().close(fig)
    return path


def mu_law(v_tilde, mu0, B, w, mu_ss, v0_tilde):
    """mu(v~) of Eq. 4: mu0 below v~0, mu0 (B exp(-w (v~ - v~0)) + mu_ss) above."""
    v = np.asarray(v_tilde, float)
    return np.where(v <= v0_tilde, mu0, mu0 * (B * np.exp(-w * (v - v0_tilde)) + mu_ss))


# --------------------------------------------------------------------------- Fig. 1
def fig_packing(out, path):
    """The relaxed packing: bulk disks, the ``top`` line (loaded) and the wall.

    Spheres: their side view (projection on the x-y plane), the ``top`` layer."""
    plt = _plt()
    from matplotlib.collections import PatchCollection
    from matplotlib.patches import Circle
    from remote_trigger.analysis.state.dumpfile import read_equilibrium
    from remote_trigger.pywrap.stages.common import packing_fraction

    st = read_equilibrium(os.path.join(out, "relax", "equilibrium.dump"))
    top = st.external[:, 1] != 0
    L = st.box_hi[0] - st.box_lo[0]
    fig, ax = plt.subplots(figsize=(5.2, 5.6))
    col = np.where(top, "tab:red", np.where(st.radii > 0.6, "tab:blue", "lightsteelblue"))
    # spheres: drawn from the back (small z) to the front
    order = np.argsort(st.positions[:, 2], kind="stable") if st.positions.shape[1] == 3 \
        else slice(None)
    pos, radii, col = st.positions[order], st.radii[order], col[order]
    for shift in (-L, 0.0, L):          # periodic images of disks that cross x = 0, L
        x = pos[:, 0] + shift
        near = (x + radii > st.box_lo[0] - 0.8) & (x - radii < st.box_hi[0] + 0.8)
        circles = [Circle((xi, yi), r) for xi, yi, r in
                   zip(x[near], pos[near, 1], radii[near])]
        ax.add_collection(PatchCollection(circles, facecolor=col[near], edgecolor="k",
                                          lw=0.4, alpha=1.0 if shift == 0 else 0.35))
    ax.axhline(0.0, color="k", lw=2)
    ax.axvline(st.box_lo[0], color="gray", ls=":", lw=1)
    ax.axvline(st.box_hi[0], color="gray", ls=":", lw=1)
    h = float(np.max(pos[:, 1] + radii))
    ax.set_xlim(st.box_lo[0] - 0.8, st.box_hi[0] + 0.8)
    ax.set_ylim(-0.5, h + 0.8)
    ax.set_aspect("equal")
    ax.set_xlabel(r"$x$ [$\sigma = 2R_1$]")
    ax.set_ylabel(r"$y$ [$\sigma$]")
    phi = packing_fraction(st)
    if st.positions.shape[1] == 3:
        title = (f"relaxed packing, N = {st.n} spheres (side view), $\\phi$ = {phi:.4f}\n"
                 f"red: top layer loaded by $(F_x, -F_y, 0)$; periodic in x, z (L = {L:.3f})")
    else:
        title = (f"relaxed packing, N = {st.n}, $\\phi$ = {phi:.4f}\n"
                 f"red: top line loaded by $(F_x, -F_y)$; periodic in x (L = {L:.3f})")
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    return _save(fig, path)


# --------------------------------------------------------------------------- Fig. 2
def fig_mu_law(summary, path):
    """mu(v)/mu0 vs v/v_ss on a log axis, with the threshold v0 marked."""
    plt = _plt()
    cfg = summary["config"]
    pert = summary.get("perturb") or {}
    v0, vss = pert.get("v0", float("nan")), pert.get("v_ss", float("nan"))
    v0t = v0 / vss if np.isfinite(v0) and np.isfinite(vss) and vss > 0 else 1.0
    vt = np.logspace(-2, 2.5, 600)
    mu = mu_law(vt, 1.0, cfg["B"], cfg["w"], cfg["mu_ss"], v0t)
    fig, ax = plt.subplots(figsize=(5.2, 3.8))
    ax.semilogx(vt, mu, "k-", lw=2)
    ax.axvline(v0t, color="tab:red", ls="--", lw=1)
    ax.axhline(cfg["mu_ss"], color="gray", ls=":", lw=1)
    ax.text(v0t * 1.15, 0.99, r"$\tilde v_0$", color="tab:red", va="top")
    ax.text(vt[0] * 1.2, cfg["mu_ss"] + 0.005, r"$\mu_{ss}$", color="gray", va="bottom")
    ax.set_xlabel(r"$\tilde v = v / v_{ss}$ (v: mean x-velocity of the top line)")
    ax.set_ylabel(r"$\mu(\tilde v) / \mu_0$")
    note = (f"v0 = v_ss = {v0:.3g} sigma/tau (margin x largest |v| of run (a))"
            if np.isfinite(v0)
            else "v0 = v_ss (from run (a))")
    ax.set_title(f"Eq. 4: B = {cfg['B']:g}, w = {cfg['w']:g}, $\\mu_{{ss}}$ = "
                 f"{cfg['mu_ss']:g}\n{note}", fontsize=9)
    ax.set_ylim(cfg["mu_ss"] - 0.03, 1.03)
    fig.tight_layout()
    return _save(fig, path)


# --------------------------------------------------------------------------- Fig. 3
def fig_eigenvalues(out, summary, path):
    """Re and Im of the coalescing pair vs F_x, both mu; inset near onset (main mu)."""
    plt = _plt()
    cfg = summary["config"]
    tracks = rep.tracks(out, summary)
    colors = {0: "tab:red", 1: "tab:blue"}
    fig, (axr, axi) = plt.subplots(1, 2, figsize=(10.5, 4.3))
    lam_cs = [tr.lam_c for tr in tracks.values() if tr is not None]
    shift = len(lam_cs) == 2 and abs(lam_cs[0] - lam_cs[1]) > 0.02 * max(lam_cs)
    for k, tr in tracks.items():
        mu = cfg["mu"] if k == 0 else cfg["mu_low"]
        if tr is None:
            continue
        c = colors[k]
        off = tr.lam_c if shift else 0.0
        st = ".-" if k == 0 else "-"
        lab = rf"$\mu$ = {mu:g}" + (rf" ($\lambda_c$ = {tr.lam_c:.6g})" if shift else "")
        axr.plot(tr.F_x, tr.lam_a.real - off, st, color=c, ms=2.5, lw=1.2, label=lab)
        axr.plot(tr.F_x, tr.lam_b.real - off, st, color=c, ms=2.5, lw=1.2)
        axi.plot(tr.F_x, tr.lam_b.imag, st, color=c, ms=2.5, lw=1.2, label=rf"$\mu$ = {mu:g}")
        axi.plot(tr.F_x, tr.lam_a.imag, st, color=c, ms=2.5, lw=1.2)
        Fc = tr.F_x[np.argmax(tr.complex_pair)]
        for ax in (axr, axi):
            ax.axvline(Fc, color=c, ls=":", lw=0.8)
    F5 = (summary.get("perturb") or {}).get("F_x")
    if F5:
        for ax in (axr, axi):
            ax.axvline(F5, color="k", lw=1)
    label = F_LABEL.replace("disk", "sphere") if summary["config"].get("dim", 2) == 3 \
        else F_LABEL
    axr.set_xlabel(label)
    axi.set_xlabel(label)
    axr.set_ylabel((r"Re $\lambda - \lambda_c$" if shift else r"Re $\lambda$")
                   + r"  [$1/\tau^2$]")
    axi.set_ylabel(r"Im $\lambda$  [$1/\tau^2$]")
    axr.set_title("(a) the two real eigenvalues of $M^{-1}K$ that coalesce", fontsize=10)
    axi.set_title("(b) the imaginary parts born at $F_x^c$", fontsize=10)
    axr.legend(fontsize=8, loc="best")
    axi.legend(fontsize=8, loc="lower left")
    # inset: main mu near onset
    tr = tracks.get(0)
    if tr is not None:
        Fc = tr.F_x[np.argmax(tr.complex_pair)]
        F_lo = tr.F_x[np.argmax(tr.complex_pair) - 1]
        w = max(4 * (Fc - F_lo), 2.5 * cfg["dF_x"])
        sel = (tr.F_x > Fc - w) & (tr.F_x < Fc + w)
        if np.count_nonzero(sel) >= 3:
            ins = axi.inset_axes([0.08, 0.56, 0.42, 0.38])
            half_gap = 0.5 * (tr.lam_b.real - tr.lam_a.real)
            ins.plot(tr.F_x[sel], tr.lam_b.imag[sel], "o-", color="tab:red", ms=2.5, lw=1,
                     label="Im")
            ins.plot(tr.F_x[sel], half_gap[sel], "s--", color="tab:orange", ms=2.5, lw=1,
                     label=r"$\frac{1}{2}$ gap of Re")
            ins.axvline(Fc, color="tab:red", ls=":", lw=0.8)
            ins.set_title(rf"onset, $\mu$ = {cfg['mu']:g}", fontsize=7)
            ins.tick_params(labelsize=6)
            ins.xaxis.get_offset_text().set_fontsize(6)
            ins.legend(fontsize=6, loc="center left")
    fig.suptitle("Fig. 3: eigenvalues of $M^{-1}K$ vs $F_x$ (dotted: $F_x^c$; black: "
                 "$F_x$ of Fig. 5)", fontsize=10)
    fig.tight_layout()
    return _save(fig, path)


# --------------------------------------------------------------------------- Fig. 4
def fig_msd(out, summary, path):
    """D(t) above F_x^c with exp(2 g t), g predicted by the eigenvalues."""
    plt = _plt()
    m = rep.instability_metrics(out, summary)
    t, D = m["t"], m["D"]
    fig, ax = plt.subplots(figsize=(6.2, 4.3))
    pos = D > 0
    ax.semilogy(t[pos], D[pos], "-", color="tab:blue", lw=1, label="simulation (undamped)")
    g = m["predicted_growth_rate"]
    win = m["window"]
    if g > 0 and win is not None:
        sl = slice(win[0], win[1] + 1)
        # anchor: least-squares offset of ln D - 2 g t over the window
        c = float(np.mean(np.log(D[sl]) - 2 * g * t[sl]))
        tt = np.linspace(t[win[0]], t[win[1]], 50)
        ax.semilogy(tt, np.exp(c + 2 * g * tt), "r--", lw=2,
                    label=rf"$e^{{2 g t}}$, g = max Im $\sqrt{{\lambda}}$ = {g:.4g} "
                          r"[$1/\tau$]")
        ax.axvspan(t[win[0]], t[win[1]], color="0.9", zorder=0,
                   label=f"fit window (measured g = {m['measured_growth_rate']:.4g})")
    ax.set_xlabel(T_LABEL)
    ax.set_ylabel(D_LABEL)
    F = summary["instability"]["F_x"]
    ax.set_title(f"Fig. 4: $\\mu$ = {summary['config']['mu']:g}, $F_x$ = {F:.5g} = "
                 f"{summary['config']['fig4_ratio']:.4g} $F_x^c$; "
                 f"{m['decades']:.1f} decades of growth", fontsize=9)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    return _save(fig, path)


# --------------------------------------------------------------------------- Fig. 5
def fig_perturb(out, summary, path):
    """(a) D(t) of runs (a)-(d); (b) mu(v(t)) vs |v| of run (c) with Eq. 4 and mu*;
    (c) |v_top(t)| of the runs."""
    plt = _plt()
    cfg = summary["config"]
    pz = summary["perturb"]
    m = rep.perturb_metrics(out, summary)
    fig, axs = plt.subplots(1, 3, figsize=(15, 4.4))
    colors = {"a": "tab:blue", "b": "tab:green", "c": "tab:red", "d": "tab:purple",
              "e": "tab:orange", "p": "tab:gray"}
    ctl = (pz.get("control") or {}).get("F_x", float("nan"))
    labels = {"a": "(a) unperturbed", "b": r"(b) $f(t)$",
              "c": r"(c) $f(t)$ + $\mu(v)$",
              "d": rf"(d) control: $f(t)$ + $\mu(v)$ at $F_x$ = {ctl:.4g}",
              "p": rf"(p) paper's $a$ = {cfg['a_paper']:g} + $\mu(v)$"}
    for k in "abcdp":
        s = m["series"].get(k)
        if s is None:
            continue
        pos = s["D"] > 0
        axs[0].semilogy(s["t"][pos], s["D"][pos], "-", color=colors[k], lw=0.8,
                        label=labels[k])
        v = np.abs(s["v_top"])
        axs[2].semilogy(s["t"][v > 0], v[v > 0], "-", color=colors[k], lw=0.6,
                        label=labels[k])
    axs[2].axhline(m["v0"], color="k", ls=":", lw=1, label=r"$v_0$")
    axs[0].set_xlabel(T_LABEL)
    axs[0].set_ylabel(D_LABEL)
    w = pz.get("window", [float("nan")] * 2)
    axs[0].set_title(f"(a) $F_x$ = {pz['F_x']:.5g} in [{w[0]:.5g}, {w[1]:.5g}], "
                     f"$a$ = {pz.get('a', float('nan')):.2g}, $\\omega_p$ = {cfg['omega_p']:g}",
                     fontsize=9)
    axs[0].legend(fontsize=7)
    c = m["series"].get("c")
    if c is not None:
        v = np.abs(c["v_top"])
        ok = v > 0
        axs[1].semilogx(v[ok], c["mu"][ok], ".", color="tab:red", ms=2,
                        label="run (c): $\\mu(v(t))$")
        v0, vss = m["v0"], m["v_ss"]
        if np.isfinite(v0) and v0 > 0 and ok.any():
            vv = np.logspace(np.log10(max(v[ok].min(), 1e-30)), np.log10(v[ok].max()), 400)
            axs[1].semilogx(vv, mu_law(vv / vss, cfg["mu"], cfg["B"], cfg["w"], cfg["mu_ss"],
                                       v0 / vss), "k-", lw=1, label="Eq. 4")
            axs[1].axvline(v0, color="gray", ls=":", lw=1, label="$v_0$")
        ms = pz.get("mu_star") or {}
        if np.isfinite(ms.get("low", float("nan"))):
            axs[1].axhline(0.5 * (ms["low"] + ms["high"]), color="tab:purple", ls="--", lw=1,
                           label=rf"$\mu^*$ = {0.5 * (ms['low'] + ms['high']):.4g}")
    axs[1].set_xlabel(r"$|v|$, mean x-velocity of the top line " + V_LABEL)
    axs[1].set_ylabel(r"friction coefficient $\mu$")
    rc = m.get("c") or {}
    axs[1].set_title(f"(b) $\\mu(v)$ in run (c); |v| rises {rc.get('v_decades', float('nan')):.1f}"
                     " decades above the noise of (a)", fontsize=9)
    axs[1].legend(fontsize=7)
    axs[2].set_xlabel(T_LABEL)
    axs[2].set_ylabel(r"$|v_{top}|$ " + V_LABEL)
    axs[2].set_title("(c) velocity of the top line", fontsize=9)
    axs[2].legend(fontsize=7)
    fig.tight_layout()
    return _save(fig, path)


# --------------------------------------------------------------------------- all
def make_all(out, summary):
    """Write every figure whose data exist; returns ``{name: path or 'error: ...'}``."""
    figs = {}
    jobs = [("fig1_packing", lambda p: fig_packing(out, p)),
            ("fig2_mu_law", lambda p: fig_mu_law(summary, p))]
    if any(r.get("status") == "complete" for r in summary.get("ramps", [])):
        jobs.append(("fig3_eigenvalues", lambda p: fig_eigenvalues(out, summary, p)))
    if summary.get("instability"):
        jobs.append(("fig4_msd", lambda p: fig_msd(out, summary, p)))
    if summary.get("perturb"):
        jobs.append(("fig5_perturb", lambda p: fig_perturb(out, summary, p)))
    for name, fn in jobs:
        path = os.path.join(out, name + ".png")
        try:
            figs[name] = fn(path)
        except Exception as exc:  # noqa: BLE001 - reported, the report still gets written
            figs[name] = f"error: {type(exc).__name__}: {exc}"
    nf = os.path.join(out, "fig_normal_form.png")
    if os.path.exists(nf):
        figs["fig_normal_form"] = nf
    return figs
