"""What the virtual ice tests of :mod:`siku_plugins.lab` report: strength against bond
strength (Orzech et al. 2018, Fig. 3), the stress–strain pictures, and the calibration of
``siku lab calibrate``.

**Calibration.** The macro strength of every test is proportional to the bond strength
(``sigma_crit = tau_crit``): the model is linear elastic up to brittle failure and the bond
strength is its only stress scale (docs/explanation/lab.md §3; the lines through four bond
strengths have R² = 1.0000). So one run of each test at a reference bond strength ``b0`` gives
its ratio ``r = S / b0``, and a wanted range ``[lo, hi]`` of the macro strength ``S`` is met by
the bond strengths ``[lo / r, hi / r]``. :func:`calibrate` intersects these intervals over the
tests given, takes their geometric middle (the bond strength furthest, in ratio, from both
ends) and runs every test again at it to show the macro strengths it gives. When the intervals
do not meet, no bond strength of this law and packing satisfies all ranges: the error names the
two tests whose ranges conflict and the bond strengths each needs.
"""
from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from siku_core.errors import SikuError

from .lab import TESTS, LabResult, block_extent, virtual_test


@dataclass
class StrengthTable:
    """Macro strength against bond strength for one test (Orzech et al. Fig. 3)."""

    test: str
    results: list[LabResult]
    slope: float  # macro strength per bond strength [1]
    intercept: float  # [Pa]
    r2: float  # coefficient of determination of the linear fit

    def rows(self) -> list[str]:
        out = [f"{self.test}: bond strength [MPa] | macro strength [MPa] | ratio | modulus "
               "[GPa] | bonds broken (tension/shear) | elements"]
        for r in self.results:
            out.append(f"  {r.sigma_crit / 1e6:8.3f} | {r.strength / 1e6:8.4f} | {r.ratio:6.3f} "
                       f"| {r.modulus / 1e9:6.3f} | {r.broken.get('tension', 0)}/"
                       f"{r.broken.get('shear', 0)} | {r.n_elements}")
        out.append(f"  linear fit: macro = {self.slope:.4f} × bond + {self.intercept / 1e6:.4f} "
                   f"MPa, R² = {self.r2:.4f}")
        return out


def strength_table(test: str, strengths: list[float], progress: bool = False,
                   **kwargs: Any) -> StrengthTable:
    """:func:`virtual_test` at each bond strength [Pa] (``sigma_crit = tau_crit``), and the
    least-squares line through the macro strengths."""
    results = []
    for s in strengths:
        if progress:
            print(f"siku lab: {test} at bond strength {s / 1e6:g} MPa ...", file=sys.stderr)
        results.append(virtual_test(test, s, **kwargs))
    x = np.array([r.sigma_crit for r in results])
    y = np.array([r.strength for r in results])
    if len(x) >= 2:
        slope, intercept = np.polyfit(x, y, 1)
        pred = slope * x + intercept
        ss = float(((y - y.mean()) ** 2).sum())
        r2 = 1.0 - float(((y - pred) ** 2).sum()) / ss if ss > 0 else 1.0
    else:
        slope, intercept, r2 = y[0] / x[0], 0.0, math.nan
    return StrengthTable(test, results, float(slope), float(intercept), r2)


def plot_curves(tables: list[StrengthTable], path: Path) -> Path:
    """Stress–strain curves of every run (one panel per test) and the strength lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(tables) + 1, figsize=(4.2 * (len(tables) + 1), 3.6),
                             constrained_layout=True)
    for ax, tab in zip(axes, tables):
        for r in tab.results:
            ax.plot(r.strain * 1e3, r.stress / 1e6, label=f"bond {r.sigma_crit / 1e6:g} MPa")
        ax.set_xlabel("macro strain [10⁻³]")
        ax.set_ylabel("macro stress [MPa]")
        ax.set_title(f"virtual {tab.test} test")
        ax.legend(fontsize=7)
    ax = axes[-1]
    for tab in tables:
        x = np.array([r.sigma_crit for r in tab.results]) / 1e6
        y = np.array([r.strength for r in tab.results]) / 1e6
        ax.plot(x, y, "o", label=f"{tab.test} (slope {tab.slope:.2f}, R² {tab.r2:.3f})")
        ax.plot(x, tab.slope * x + tab.intercept / 1e6, "-", lw=0.8)
    lim = max(r.sigma_crit for t in tables for r in t.results) / 1e6
    ax.plot([0, lim], [0, lim], "k:", lw=0.8, label="macro = bond")
    ax.set_xlabel("bond strength [MPa]")
    ax.set_ylabel("macro strength [MPa]")
    ax.set_title("strength against bond strength")
    ax.legend(fontsize=7)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path



def feasible_bonds(ranges: dict[str, tuple[float, float]],
                   ratios: dict[str, float]) -> tuple[float, float, str, str]:
    """The bond strengths [Pa] that put every test's macro strength ``ratio × bond`` in its
    range ``[lo, hi]`` [Pa]: ``(low, high, test_low, test_high)``, the tests that set the two
    ends (``low > high``: none does)."""
    lows = {t: ranges[t][0] / ratios[t] for t in ranges}
    highs = {t: ranges[t][1] / ratios[t] for t in ranges}
    t_lo = max(lows, key=lows.get)
    t_hi = min(highs, key=highs.get)
    return lows[t_lo], highs[t_hi], t_lo, t_hi


@dataclass
class Calibration:
    """The bond strength ``bond`` [Pa] that puts the macro strengths in ``ranges`` [Pa]."""

    ranges: dict[str, tuple[float, float]]
    reference: float  # bond strength of the first runs [Pa]
    ratios: dict[str, float]  # macro / bond at the reference [1]
    low: float  # the feasible bond strengths [Pa]
    high: float
    bond: float  # their geometric middle [Pa]
    check: dict[str, float]  # macro strength of each test run at ``bond`` [Pa]

    def rows(self) -> list[str]:
        out = [f"calibration: test | wanted macro strength [MPa] | macro / bond at "
               f"{self.reference / 1e6:g} MPa | bond strengths that meet it [MPa]"]
        for t, (lo, hi) in self.ranges.items():
            r = self.ratios[t]
            out.append(f"  {t:<11} | {lo / 1e6:.4g} .. {hi / 1e6:.4g} | {r:.4f} | "
                       f"{lo / r / 1e6:.4g} .. {hi / r / 1e6:.4g}")
        out.append(f"  all ranges: bond strength {self.low / 1e6:.4g} .. {self.high / 1e6:.4g} "
                   f"MPa; chosen (geometric middle): {self.bond / 1e6:.4g} MPa")
        for t, s in self.check.items():
            out.append(f"  check at {self.bond / 1e6:.4g} MPa: {t} macro strength "
                       f"{s / 1e6:.4g} MPa")
        return out


def calibrate(ranges: dict[str, tuple[float, float]], reference: float = 1e6,
              verify: bool = True, progress: bool = False,
              sizes: dict[str, tuple[float, float]] | None = None,
              **kwargs: Any) -> Calibration:
    """The bond strength (``sigma_crit = tau_crit``) [Pa] that puts each test's macro strength
    in its range ``ranges[test] = (lo, hi)`` [Pa] (module docstring). ``sizes[test]``: the
    block ``(length, width)`` [m]; ``kwargs`` go to :func:`~siku_plugins.lab.virtual_test`
    (element size, seed, ``jointed``, ...). ``verify``: run every test again at the result."""
    if not ranges:
        raise SikuError("calibrate: give a range for at least one test "
                        f"({', '.join(TESTS)})")
    for t, (lo, hi) in ranges.items():
        if t not in TESTS:
            raise SikuError(f"calibrate: unknown test '{t}'; one of {', '.join(TESTS)}")
        if not 0 < lo <= hi:
            raise SikuError(f"--{t} {lo / 1e6:g}:{hi / 1e6:g}: give 0 < low <= high [MPa]")
    sizes = sizes or {}

    def run(t: str, bond: float) -> LabResult:
        if progress:
            print(f"siku lab calibrate: {t} at bond strength {bond / 1e6:.4g} MPa ...",
                  file=sys.stderr)
        length, width = sizes.get(t, (None, None))
        return virtual_test(t, bond, length=length, width=width, **kwargs)

    ratios = {t: run(t, reference).strength / reference for t in ranges}
    low, high, t_lo, t_hi = feasible_bonds(ranges, ratios)
    if low > high:
        raise SikuError(
            f"no bond strength meets every range: {t_lo} needs at least {low / 1e6:.4g} MPa "
            f"(macro / bond = {ratios[t_lo]:.3f}) and {t_hi} at most {high / 1e6:.4g} MPa "
            f"(macro / bond = {ratios[t_hi]:.3f}); widen one of the two ranges")
    bond = math.sqrt(low * high)
    check = {t: run(t, bond).strength for t in ranges} if verify else {}
    return Calibration(dict(ranges), reference, ratios, low, high, bond, check)


def parse_range(text: str, option: str) -> tuple[float, float]:
    """``"LO:HI"`` [MPa] -> ``(lo, hi)`` [Pa]; a one-line error otherwise."""
    try:
        lo, hi = (float(x) * 1e6 for x in text.split(":"))
    except ValueError:
        raise SikuError(f"{option} {text!r}: give the wanted macro strength as LOW:HIGH in MPa, "
                        "e.g. 0.3:0.8") from None
    if not (0 < lo <= hi < 1e6 * 1e6) or not (math.isfinite(lo) and math.isfinite(hi)):
        raise SikuError(f"{option} {text!r}: give 0 < LOW <= HIGH in MPa")
    return lo, hi


def add_arguments(p) -> None:
    """The options of ``siku lab calibrate``."""
    for t in TESTS:
        p.add_argument(f"--{t}", metavar="LO:HI",
                       help=f"calibrate: wanted {t} macro strength [MPa], e.g. 0.3:0.8")
    p.add_argument("--reference", type=float, default=1.0,
                   help="calibrate: bond strength of the first runs [MPa] (default 1)")


def cmd_calibrate(args) -> int:
    """``siku lab calibrate --tension LO:HI --compression LO:HI --flexure LO:HI``."""
    ranges = {t: parse_range(getattr(args, t), f"--{t}") for t in TESTS
              if getattr(args, t, None)}
    if not ranges:
        raise SikuError("siku lab calibrate: give at least one of --tension, --compression, "
                        "--flexure as LOW:HIGH in MPa")
    if not 0 < args.reference < 1e6:
        raise SikuError(f"--reference {args.reference}: a bond strength in MPa, above 0")
    sizes = {t: block_extent(t, args.element_size, args.length, args.width) for t in ranges}
    cal = calibrate(ranges, args.reference * 1e6, progress=True, sizes=sizes,
                    element_size=args.element_size, seed=args.seed, jointed=args.jointed)
    print("\n".join(cal.rows()))
    return 0
