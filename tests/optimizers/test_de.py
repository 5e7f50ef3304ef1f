import itertools
import logging

import numpy as np
import pytest

from mmocap import config as mmocap_config
from mmocap.api import Optimizer, SearchSpace
from mmocap.errors import ConfigError
from mmocap.optimizers.de import DifferentialEvolution, assortative_mating
from mmocap.registry import make_optimizer
from mmocap.testing.objectives import (
    SHIFT,
    TRACKING_LIKE,
    D,
    box,
    ellipsoid_1e3,
    minimise,
    random_search,
    sphere,
)


def test_defaults_follow_table_3_but_cr_and_init_spread_and_the_yaml():
    opt = DifferentialEvolution()
    assert (opt.popsize, opt.n_placing, opt.n_leading, opt.n_correcting) == (10, 5, 5, 5)
    assert (opt.cr, opt.f) == (0.5, 0.5)
    assert (opt.init_spread, opt.include_x0) == (0.3, True)
    assert isinstance(opt, Optimizer)
    cfg = mmocap_config.load("optimizer/de.yaml")
    built = make_optimizer(**{k: v for k, v in cfg.items() if k != "_target_"})
    assert vars(built) == vars(opt)


@pytest.mark.parametrize("name", TRACKING_LIKE)
def test_default_setting_beats_random_search_and_f0(name):
    # Means over 3 seeds at the tracking budget: from f(x0) = 1.56 / 240 / 867 to
    # 0.14 / 5.5 / 70, far below random search in the box (7.9 / 636 / 2910); with F ~ 0
    # the donor is the placing vector, few new directions are made and DE stalls
    # (0.87 / 73 / 428).
    f = TRACKING_LIKE[name]
    space = box(D, 0.0, 1.0, 1.0, 1500)
    de = np.mean([minimise(DifferentialEvolution(), f, space, s).result.fbest for s in range(3)])
    rand = np.mean([random_search(f, space, s) for s in range(3)])
    no_f = np.mean([minimise(DifferentialEvolution(f=1e-9), f, space, s).result.fbest for s in range(3)])
    assert de < rand / 5
    assert de < no_f / 3
    assert de < 0.8 * f(np.zeros((1, D)))[0]


@pytest.mark.parametrize(("f", "random_factor", "f0_factor"), [(sphere, 50, 20), (ellipsoid_1e3, 30, 10)])
def test_larger_population_converges_far_from_the_start(f, random_factor, f0_factor):
    # N = 40 from x0 = 3 (f = 351 / 3.5e4) in a box of +-5, seed 0: sphere 1.8 (random
    # search 169, F ~ 0 56), ellipsoid 222 (random 1.2e4, F ~ 0 4.0e3).
    kw = dict(popsize=40, n_placing=20, n_leading=20, n_correcting=20)
    space = box(D, 3.0, 5.0, 5.0, 8000)
    r = minimise(DifferentialEvolution(**kw), f, space, 0).result
    assert r.fbest < random_search(f, space, 0) / random_factor
    assert r.fbest < minimise(DifferentialEvolution(f=1e-9, **kw), f, space, 0).result.fbest / f0_factor


def test_assortative_mating():
    rng = np.random.default_rng(0)
    Z = np.arange(6.0)[:, None] * np.ones((1, 3))  # member j at distance j*sqrt(3) from 0
    ref = Z[0]
    cands = [1, 2, 3, 4, 5]
    for _ in range(50):
        keys = rng.random(6)
        assert assortative_mating(cands, Z, ref, 1.0, keys) == 1  # nearest of all
        assert assortative_mating(cands, Z, ref, -1.0, keys) == 5  # farthest of all
        # |alpha| = 0.5: nearest (farthest) of 3 random candidates, never the 2 farthest
        # (nearest)
        assert assortative_mating(cands, Z, ref, 0.5, keys) in (1, 2, 3)
        assert assortative_mating(cands, Z, ref, -0.5, keys) in (3, 4, 5)
    picks = [assortative_mating(cands, Z, ref, 0.0, rng.random(6)) for _ in range(2000)]
    counts = np.bincount(picks, minlength=6)[1:]
    assert np.all(np.abs(counts / 2000 - 0.2) < 0.04)  # alpha = 0: random mating


def started(seed=0, budget=1000, bound=100.0, **kw):
    """Optimiser after generation 0 on the sphere; x0 = 0 and radius = 1, so normalised
    coordinates are the original ones."""
    opt = DifferentialEvolution(**kw)
    opt.setup(box(D, 0.0, bound, 1.0, budget), np.random.default_rng(seed))
    X = opt.ask()
    opt.tell(X, sphere(X))
    return opt, X, sphere(X)


@pytest.mark.parametrize("kw", [{}, dict(n_placing=1, n_leading=2, n_correcting=1)])
def test_mates_follow_the_roles(kw):
    opt, X, f = started(**kw)
    order = np.argsort(f)
    best = lambda k: set(order[:k].tolist())  # noqa: E731
    worst = set(order[10 - opt.n_correcting :].tolist())
    everyone = set(range(10))
    for _ in range(30):
        idx, alpha = opt.mates()
        for i, (p, l, c) in enumerate(idx):
            assert len({i, p, l, c}) == 4
            # a role set emptied by the exclusions falls back to the rest of the population
            assert p in (best(opt.n_placing) - {i} or everyone - {i})
            assert l in (best(opt.n_leading) - {i, p} or everyone - {i, p})
            assert c in (worst - {i, p, l} or everyone - {i, p, l})
        assert np.all(np.abs(alpha) <= 1)


def test_trials_inherit_the_placing_vectors_alpha_altered_with_probability_0_1():
    opt, _, _ = started()
    inherited = []
    for _ in range(200):
        idx, alpha = opt.mates()
        inherited.append(alpha == opt._alpha[idx[:, 0]])
    assert np.mean(inherited) == pytest.approx(0.9, abs=0.02)


def test_trials_are_eq_15_donors_of_role_vectors_with_cr_1():
    opt, X, f = started(cr=1.0)
    U = opt.ask()  # bounds of +-100: nothing is clipped
    order = np.argsort(f)
    for i, u in enumerate(U):
        found = [
            (p, l, c) for p, l, c in itertools.permutations(range(10), 3) if np.allclose(u, X[p] + 0.5 * (X[l] - X[c]))
        ]
        assert len(found) == 1
        p, l, c = found[0]
        assert i not in (p, l, c)
        assert p in order[:5]
        assert l in order[:5]
        assert c in order[5:]


def test_crossover_with_cr_0_changes_one_coordinate():
    opt, X, _ = started(cr=0.0)
    U = opt.ask()
    assert np.all(np.sum(U != X, axis=1) == 1)


def test_selection_keeps_the_better_of_receiver_and_trial_in_a_truncated_generation():
    opt, X, f = started(budget=15)
    U = opt.ask()
    assert U.shape == (5, D)  # the budget leaves 5 evaluations
    trial_alpha = opt._trial_alpha.copy()
    old_alpha = opt._alpha.copy()
    fu = np.array([0.0, 1e9, 0.0, 1e9, f[4]])  # trials 0, 2 win; 4 ties and wins
    opt.tell(U, fu)
    won = np.array([True, False, True, False, True] + [False] * 5)
    np.testing.assert_array_equal(opt._Z[won], U[[0, 2, 4]])
    np.testing.assert_array_equal(opt._Z[~won], X[~won])
    np.testing.assert_array_equal(opt._fit, np.where(won, np.r_[fu, f[5:]], f))
    np.testing.assert_array_equal(opt._alpha[won], trial_alpha[won])
    np.testing.assert_array_equal(opt._alpha[~won], old_alpha[~won])
    assert opt.stop() == {"budget": 15}


def spread_trace(f, checkpoints, seed=0, **kw):
    """Mean spread (search radii) after each number of evaluations in ``checkpoints`` on
    ``f`` in the tracking-like box (x0 = 0, bounds +-1, radius = 1, 1500 evaluations)."""
    opt = DifferentialEvolution(**kw)
    opt.setup(box(D, 0.0, 1.0, 1.0, 1500), np.random.default_rng(seed))
    trace = []
    while not opt.stop():
        X = opt.ask()
        opt.tell(X, f(X))
        if opt.evaluations in checkpoints:
            trace.append(opt.spread().mean())
    return np.array(trace)


NO_ROLE_SPLIT = dict(n_placing=10, n_leading=10, n_correcting=10)


def flat(X):
    return np.zeros(len(X))


def test_spread_is_the_population_std_in_search_radii():
    opt = DifferentialEvolution()
    opt.setup(box(D, 0.0, 1.0, 2.0, 100), np.random.default_rng(0))
    with pytest.raises(RuntimeError, match="generation 0"):
        opt.spread()
    X = opt.ask()
    opt.tell(X, sphere(X))
    np.testing.assert_allclose(opt.spread(), X.std(axis=0) / 2.0)
    # uniform in +-0.3 radii: std 0.3 / sqrt(3) = 0.17 per coordinate, 0.15 with x0 a member
    assert 0.12 < opt.spread().mean() < 0.19


def test_spread_shrinks_on_the_sphere():
    # seed 0: 0.16, 1.1e-2, 1.4e-3, 6.9e-4
    trace = spread_trace(TRACKING_LIKE["sphere"], (10, 500, 1000, 1500))
    assert np.all(np.diff(trace) < 0)
    assert trace[-1] < trace[0] / 50


def test_role_split_collapses_the_spread_even_on_a_flat_function():
    # Flat, seed 0: 0.16 -> 1.3e-3 with the defaults, 0.16 -> 0.10 with N_P = N_L = N_C = N
    # (0.38 at 600 evaluations); every fitness ties, so the same members keep the roles.
    roles = spread_trace(flat, (10, 1500))
    no_split = spread_trace(flat, (10, 1500), **NO_ROLE_SPLIT)
    assert roles[1] < roles[0] / 10
    assert no_split[1] > no_split[0] / 2


def test_role_split_narrows_the_spread_on_the_sphere():
    # Sphere, seeds 0-2, after 1500 evaluations: 5.7e-4 with the defaults against 2.8e-3
    # with N_P = N_L = N_C = N; the best values are alike (0.14 and 0.12 over seeds 0-4).
    f = TRACKING_LIKE["sphere"]
    roles = np.mean([spread_trace(f, (1500,), s)[0] for s in range(3)])
    no_split = np.mean([spread_trace(f, (1500,), s, **NO_ROLE_SPLIT)[0] for s in range(3)])
    assert roles < no_split / 2


def test_end_of_search_logs_the_spread(caplog):
    opt = DifferentialEvolution()
    with caplog.at_level(logging.DEBUG, logger="mmocap.optimizers.de"):
        minimise(opt, sphere, box(D, 0.0, 1.0, 1.0, 95), 0)
    messages = [r.getMessage() for r in caplog.records if r.name == "mmocap.optimizers.de"]
    assert messages == [
        f"de: population spread after 95 evaluations: mean {opt.spread().mean():.3g}, "
        f"min {opt.spread().min():.3g}, max {opt.spread().max():.3g} search radii "
        f"over {D} coordinates"
    ]


@pytest.mark.parametrize(("budget", "last"), [(10, 10), (11, 1), (95, 5), (100, 10), (1500, 10)])
def test_budget_is_hit_exactly(budget, last):
    opt = DifferentialEvolution()
    run = minimise(opt, lambda X: sphere(X, SHIFT), box(D, 0.0, 1.0, 1.0, budget), 1)
    asked = run.asked
    r = run.result
    assert sum(len(X) for X in asked) == r.evaluations == budget
    assert [len(X) for X in asked[:-1]] == [10] * (len(asked) - 1)
    assert len(asked[-1]) == last
    assert r.stop_reasons == {"budget": budget}
    with pytest.raises(RuntimeError, match="budget"):
        opt.ask()


def test_budget_smaller_than_the_population_is_a_config_error():
    with pytest.raises(ConfigError, match="at least 10 evaluations"):
        DifferentialEvolution().setup(box(D, 0.0, 1.0, 1.0, 9), np.random.default_rng(0))


def test_asked_points_stay_in_bounds_and_optimum_on_bound_is_found():
    space = SearchSpace(x0=np.full(5, 0.9), lower=-np.ones(5), upper=np.ones(5), radius=np.full(5, 2.0), budget=2000)
    run = minimise(DifferentialEvolution(), lambda X: np.sum((X - 2.0) ** 2, axis=1), space, 3)
    asked = run.asked
    r = run.result
    X = np.concatenate(asked)
    assert np.all(X >= space.lower)
    assert np.all(X <= space.upper)
    assert r.fbest == pytest.approx(5.0, abs=1e-6)


@pytest.mark.parametrize(
    ("kw", "name"),
    [
        (dict(popsize=3), "popsize"),
        (dict(popsize=10.5), "popsize"),
        (dict(n_placing=11), "n_placing"),
        (dict(n_placing=0), "n_placing"),
        (dict(n_leading=11), "n_leading"),
        (dict(n_correcting=0), "n_correcting"),
        (dict(popsize=6, n_correcting=7), "n_correcting"),
        (dict(cr=-0.1), "cr"),
        (dict(cr=1.5), "cr"),
        (dict(f=0.0), "f"),
        (dict(f=-0.5), "f"),
        (dict(f=float("nan")), "f"),
        (dict(init_spread=0.0), "init_spread"),
        (dict(include_x0="yes"), "include_x0"),
    ],
)
def test_bad_parameters_are_config_errors(kw, name):
    with pytest.raises(ConfigError, match=rf"optimizer\.{name}\b"):
        DifferentialEvolution(**kw)
