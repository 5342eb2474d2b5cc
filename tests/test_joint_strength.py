"""Joints of unequal strength (``joint_strength``, siku_plugins.processes.joint_strength) and
the distributed spring's per-joint strength factor.

* The factors are Weibull of modulus ``m`` and mean 1: over ``n`` joints their empirical
  distribution is within the Kolmogorov-Smirnov 1 % critical distance ``1.63 / sqrt(n)`` of
  ``1 - exp(-(x / s)^m)``, and their mean within three standard errors (``CV / sqrt(n)``) of 1.
* A joint's factor depends on the seed and its two elements only: the same for the pairs in
  any order, either way round.
* A joint of factor ``X`` breaks above ``X`` times the law's strain, not below; factor 1 (the
  default, log 0) is the law as before.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from siku_plugins.processes.joint_strength import weibull_factors


@pytest.mark.parametrize("m", [2.0, 5.0])
def test_the_factors_are_weibull_with_mean_one(m):
    n = 4000
    rng = np.random.default_rng(1)
    ji = rng.integers(0, 10**6, n)
    jj = ji + 1 + rng.integers(0, 10, n)
    x = np.sort(weibull_factors(ji, jj, m, seed=7))
    s = 1.0 / math.gamma(1.0 + 1.0 / m)
    cdf = 1.0 - np.exp(-((x / s) ** m))
    k = np.arange(1, n + 1) / n
    D = max(np.max(k - cdf), np.max(cdf - (k - 1.0 / n)))
    assert D < 1.63 / math.sqrt(n)
    cv = math.sqrt(math.gamma(1 + 2 / m) / math.gamma(1 + 1 / m) ** 2 - 1)
    assert abs(x.mean() - 1.0) < 3 * cv / math.sqrt(n)


def test_a_joints_factor_is_its_pairs_whatever_the_order():
    ji, jj = np.array([3, 10, 4, 0]), np.array([4, 2, 9, 1])
    f = weibull_factors(ji, jj, 3.0, seed=2)
    order = [2, 0, 3, 1]
    np.testing.assert_array_equal(weibull_factors(jj[order], ji[order], 3.0, seed=2), f[order])
    assert not np.array_equal(weibull_factors(ji, jj, 3.0, seed=3), f)


def _strain_test(factor_log: float | None, strain: float) -> bool:
    """Whether a joint of length 1 m stretched uniformly by ``strain`` breaks."""
    from siku_core.contact_law import J_DTM, J_K, J_L0, J_MEFF, J_S1X, J_S2X, J_SIZE, J_W
    from siku_plugins.contact_laws.spring import SPRING_RECORD, spring_evaluator

    g = np.zeros(J_SIZE)
    g[J_L0], g[J_W], g[J_K], g[J_MEFF], g[J_DTM] = 1.0, 1.0, 1e9, 1e3, 1e-3
    g[J_S1X] = g[J_S2X] = strain
    pars = SPRING_RECORD.pack({"tensile_strain": 1e-4, "joint_damping_ratio": 0.1,
                               "damage_onset": 1.0})
    hist = np.array([0.0, factor_log]) if factor_log is not None else np.zeros(1)
    out = np.zeros(4)
    spring_evaluator(g, pars, hist, out)
    return out[3] != 0


def test_a_joint_breaks_at_its_own_strength():
    assert not _strain_test(0.0, 0.99e-4) and _strain_test(0.0, 1.01e-4)
    assert not _strain_test(math.log(2.0), 1.99e-4) and _strain_test(math.log(2.0), 2.01e-4)
    assert _strain_test(math.log(0.5), 0.51e-4)
    # a law wrapping the evaluator with one history column has the law's strength
    assert not _strain_test(None, 0.99e-4) and _strain_test(None, 1.01e-4)


def _scene(law: str):
    from siku_core.scene.scene_file import scene_from_text
    from siku_core.testing import scene_text
    from siku_core.testing.contact_cases import square_pack

    txt = scene_text([], packs=[square_pack(0.0, 0.0, 6, 4, size=100.0)], dt=0.01,
                     duration=0.02, thickness=1.0, extra=(
                         f'[contact]\nlaw = "{law}"\n\n'
                         '[[process]]\nname = "joint_strength"\n'
                         'params = { modulus = 3.0, seed = 5 }\n'))
    return scene_from_text(txt, "<pack>")


def test_the_process_sets_each_joints_factor_in_a_run():
    from siku_core.run.simulation import Simulation

    sim = Simulation(_scene("distributed_spring"), out=False, progress=False)
    cm = sim.context.contacts  # the view processes see
    n = cm.n_joints
    assert n > 20
    want = np.log(weibull_factors(np.asarray(cm.ji), np.asarray(cm.jj), 3.0, 5))
    assert cm.joint_history_names == ("max_strain", "log_strength")
    np.testing.assert_array_equal(cm.joint_history[:n, 1], want)
    sim.run(steps=2)
    np.testing.assert_array_equal(cm.joint_history[:n, 1], want)  # kept by the law


def test_a_law_without_strength_factors_is_refused_in_one_line():
    from siku_core.errors import SceneError
    from siku_core.run.simulation import Simulation

    with pytest.raises(SceneError, match="joint_strength.*distributed_spring"):
        Simulation(_scene("collision"), out=False, progress=False)
