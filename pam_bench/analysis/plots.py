"""Figures of an extraction in the style of 004: up sweeps solid, down sweeps dashed.

Each function writes one PNG (matplotlib, Agg backend: no display needed) and returns its
file name. Axes in the paper's units: x in mm, F in N, u in V.
"""

from __future__ import annotations

import pathlib
from typing import Any

import matplotlib

matplotlib.use('Agg')
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from pam_bench.analysis.static import isometric_gains  # noqa: E402
from pam_bench.analysis.summary import StepSummary  # noqa: E402
from pam_bench.bags.bagread import Points  # noqa: E402

__all__ = ['plot_family', 'plot_surfaces', 'plot_gains', 'plot_step_polynomials',
           'plot_model_residuals']

# what each family plots: (x column, y column, series label, axis labels)
_FAMILY = {
    'isobaric': ('set_value', 'x_mm', lambda v: f'u = {v:.1f} V', 'F, N', 'x, mm'),
    'isotonic': ('voltage_v', 'x_mm', lambda v: f'F = {v:.0f} N', 'u, V', 'x, mm'),
    'isometric': ('voltage_v', 'force_n', lambda v: f'x = {v * 1e3:.0f} mm', 'u, V', 'F, N'),
}


def _column(p: Points, name: str) -> np.ndarray:
    return p.contraction_m * 1e3 if name == 'x_mm' else getattr(p, name)


def plot_family(p: Points, kind: str, out: pathlib.Path) -> str:
    """One characteristic family (kind: isobaric, isotonic, isometric)."""
    xc, yc, label, xl, yl = _FAMILY[kind]
    fig, ax = plt.subplots(figsize=(7, 4.5))
    series = np.unique(p.series)
    colours = plt.cm.viridis(np.linspace(0, 0.9, max(len(series), 1)))
    for colour, s in zip(colours, series, strict=True):
        m = p.series == s
        for d, style in ((0, '-'), (1, '--')):
            md = m & (p.direction == d)
            if md.any():
                ax.plot(_column(p, xc)[md], _column(p, yc)[md], style, color=colour, lw=1.2,
                        label=label(float(p.series_value[m][0])) if d == 0 else None)
    ax.set_xlabel(xl)
    ax.set_ylabel(yl)
    ax.set_title(f'{p.protocol}: up solid, down dashed')
    ax.grid(alpha=0.3)
    if len(series) <= 12:
        ax.legend(fontsize=7)
    name = f'{p.protocol}_family.png'
    fig.tight_layout()
    fig.savefig(out / name, dpi=110)
    plt.close(fig)
    return name


def plot_surfaces(p: Points, kind: str, out: pathlib.Path) -> str:
    """The family as a surface over (swept value, series value) and its hysteresis surface
    (down minus up at the same set value)."""
    xc, yc, _, xl, yl = _FAMILY[kind]
    sv = np.unique(p.series_value)
    grid = np.unique(np.round(_column(p, xc), 6))
    up = np.full((len(sv), len(grid)), np.nan)
    down = np.full_like(up, np.nan)
    for i, v in enumerate(sv):
        m = p.series_value == v
        for a, y, d in zip(np.round(_column(p, xc)[m], 6), _column(p, yc)[m], p.direction[m],
                           strict=True):
            (up if d == 0 else down)[i, np.searchsorted(grid, a)] = y
    fig, axes = plt.subplots(1, 2, figsize=(10, 4))
    for ax, data, title in ((axes[0], up, f'{yl} (up)'), (axes[1], down - up,
                                                          f'hysteresis: down - up, {yl}')):
        mesh = ax.pcolormesh(grid, sv * (1e3 if kind == 'isometric' else 1.0), data,
                             shading='nearest', cmap='viridis')
        fig.colorbar(mesh, ax=ax)
        ax.set_xlabel(xl)
        ax.set_ylabel({'isobaric': 'u, V', 'isotonic': 'F, N', 'isometric': 'x, mm'}[kind])
        ax.set_title(title)
    name = f'{p.protocol}_surfaces.png'
    fig.tight_layout()
    fig.savefig(out / name, dpi=110)
    plt.close(fig)
    return name


def plot_gains(p: Points, out: pathlib.Path) -> str:
    """Isometric gain k(x), N/V."""
    x, k = isometric_gains(p)
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.plot(x * 1e3, k, 'o-')
    ax.set_xlabel('x, mm')
    ax.set_ylabel('k, N/V')
    ax.set_title('isometric gain (slope of the hysteresis midline)')
    ax.grid(alpha=0.3)
    name = 'isometric_gain.png'
    fig.tight_layout()
    fig.savefig(out / name, dpi=110)
    plt.close(fig)
    return name


def plot_step_polynomials(step: StepSummary, out: pathlib.Path) -> str:
    """b, c, d, F_a0 per fit over x with their polynomials."""
    fig, axes = plt.subplots(2, 2, figsize=(9, 6))
    for ax, key, unit in zip(axes.flat, ('b', 'c', 'd', 'F_a0'),
                             ('1/s', '1/s^2', 'N/(V s^2)', 'N'), strict=True):
        col = 'F_a0_N' if key == 'F_a0' else key
        for d, mark in (('up', 'o'), ('down', 'x')):
            pts = [(f['x_mm'], f[col]) for f in step['fits'] if f['direction'] == d]
            if pts:
                a = np.array(pts)
                ax.plot(a[:, 0], a[:, 1], mark, ms=3, alpha=0.5, label=f'{d} steps')
        poly = step['polynomials'].get(key)
        if poly:
            xs = np.linspace(min(poly['x_mm']), max(poly['x_mm']), 200)
            z = (xs - poly['x_mid_mm']) / poly['x_half_range_mm']
            ax.plot(xs, np.polynomial.polynomial.polyval(z, poly['coefficients_low_to_high']),
                    'k-', label=f"degree {poly['degree']} polynomial")
        ax.set_xlabel('x, mm')
        ax.set_ylabel(f'{key}, {unit}')
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7)
    name = 'step_coefficients.png'
    fig.tight_layout()
    fig.savefig(out / name, dpi=110)
    plt.close(fig)
    return name


def plot_model_residuals(models: list[dict[str, Any]], out: pathlib.Path) -> str:
    """Residual (model - measured, N) over x for every static force model."""
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for m in models:
        _, x, _ = m['_used']
        ax.plot(x * 1e3, m['_residuals'], '.', ms=2,
                label=f"{m['model']} ({m['n_params']} p, RMSE {m['rmse_N']:.1f} N)")
    ax.axhline(0.0, color='k', lw=0.8)
    ax.set_xlabel('x, mm')
    ax.set_ylabel('model - measured, N')
    ax.set_title('static force models fitted to the same readings')
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, markerscale=4)
    name = 'model_residuals.png'
    fig.tight_layout()
    fig.savefig(out / name, dpi=110)
    plt.close(fig)
    return name


def plot_correlation(designs: list[Any], out: pathlib.Path) -> str:
    """000's correlation graph (dL / L0 against Phi0 / L0, one line per P L0^2 / F of Table
    4) with the designs' points (``models.laws.straight_fibre.Design``) on it."""
    from pam_bench.models.laws.straight_fibre import PI2, PI3, TABLE4
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for i, pi3 in enumerate(PI3):
        ax.plot(PI2, TABLE4[i], marker='.', label=f'P L0^2/F = {pi3:g}')
    for d in designs:                        # on the graph: the ratio before the wall
        ax.plot(d.phi0_over_l0, d.segment_ratio, 'k*', markersize=9)
    ax.set_xlabel('Phi0 / L0')
    ax.set_ylabel('dL / L0')
    ax.set_title('000 correlation graph (Table 4) and the design points (*)')
    ax.legend(fontsize=7, ncol=2)
    ax.grid(True, alpha=0.3)
    path = out / 'correlation_graph.png'
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path.name
