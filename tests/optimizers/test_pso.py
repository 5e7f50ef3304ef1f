import math

import numpy as np
import pytest

from mmocap import config as mmocap_config
from mmocap.api import Optimizer, SearchSpace
from mmocap.errors import ConfigError
from mmocap.optimizers.pso import ParticleSwarm, inertia_schedule
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

PAPER = dict(v_max=None, init_spread=1.0)  # Table 3 with the paper's random start


def test_defaults_follow_table_3_and_the_yaml():
    opt = ParticleSwarm()
    assert (opt.popsize, opt.phi1, opt.phi2, opt.w_max, opt.w_min) == (10, 2.0, 2.0, 2.0, 0.1)
    assert (opt.v_max, opt.init_spread, opt.include_x0) == (0.1, 0.1, True)
    assert isinstance(opt, Optimizer)
    cfg = mmocap_config.load("optimizer/pso.yaml")
    built = make_optimizer(**{k: v for k, v in cfg.items() if k != "_target_"})
    assert vars(built) == vars(opt)


@pytest.mark.parametrize("name", TRACKING_LIKE)
def test_default_setting_beats_random_search_and_no_attraction(name):
    # Means over 3 seeds at the tracking budget: PSO reaches 0.017 / 3.3 / 16 from
    # f(x0) = 1.56 / 240 / 867; random search in the box gets 7.9 / 636 / 2910, and a swarm
    # without attraction (phi1 = phi2 = 0) 1.4 / 186 / 751.
    f = TRACKING_LIKE[name]
    space = box(D, 0.0, 1.0, 1.0, 1500)
    pso = np.mean([minimise(ParticleSwarm(), f, space, s).result.fbest for s in range(3)])
    rand = np.mean([random_search(f, space, s) for s in range(3)])
    drift = np.mean([minimise(ParticleSwarm(phi1=0.0, phi2=0.0), f, space, s).result.fbest for s in range(3)])
    assert pso < rand / 100
    assert pso < drift / 20


@pytest.mark.parametrize(("f", "popsize", "factor"), [(sphere, 10, 20), (ellipsoid_1e3, 40, 10)])
def test_paper_setting_converges_far_from_the_start(f, popsize, factor):
    # Table 3 with random positions in the whole box, from x0 = 3 (f = 351 / 3.5e4) in a box
    # of +-5, seed 0: sphere 3.7 (random search 169, phi = 0: 212), ellipsoid with N = 40:
    # 668 (random 1.2e4, phi = 0: 9.5e3).
    space = box(D, 3.0, 5.0, 5.0, 10000)
    r = minimise(ParticleSwarm(popsize=popsize, **PAPER), f, space, 0).result
    drift = minimise(ParticleSwarm(popsize=popsize, phi1=0.0, phi2=0.0, **PAPER), f, space, 0).result
    assert r.fbest < random_search(f, space, 0) / factor
    assert r.fbest < drift.fbest / factor


def test_inertia_schedule_is_eq_19():
    w = inertia_schedule(2.0, 0.1, 149)  # 1500 evaluations, N = 10: 149 moves
    g_max = 148  # inertia changes
    c = np.arange(149) * math.log(10 * 2.0) / g_max
    np.testing.assert_allclose(w, 2.0 / np.exp(c), rtol=1e-12)
    assert w[0] == 2.0
    assert w[-1] == pytest.approx(0.1, rel=1e-12)
    np.testing.assert_allclose(w[1:] / w[:-1], math.exp(-math.log(20) / g_max), rtol=1e-12)
    np.testing.assert_allclose(inertia_schedule(0.9, 0.4, 3), [0.9, 0.6, 0.4], rtol=1e-12)
    np.testing.assert_array_equal(inertia_schedule(2.0, 0.1, 1), [2.0])
    assert inertia_schedule(2.0, 0.1, 0).shape == (0,)


def test_swarm_moves_with_the_scheduled_inertia_to_the_last_truncated_generation():
    opt = ParticleSwarm()
    opt.setup(box(D, 0.0, 1.0, 1.0, 95), np.random.default_rng(0))
    used = []
    while not opt.stop():
        X = opt.ask()
        used.append(opt.inertia)
        opt.tell(X, sphere(X))
    assert math.isnan(used[0])  # generation 0 does not move
    # ceil(95 / 10) - 1 = 9 moves, the last one of 5 particles
    np.testing.assert_allclose(used[1:], 2.0 * np.exp(-np.arange(9) * math.log(20) / 8))
    assert used[-1] == pytest.approx(0.1)


def test_velocity_update_is_eq_18():
    # With phi1 = phi2 = 0 and no clamp, x moves by w * v exactly (inside wide bounds).
    opt = ParticleSwarm(phi1=0.0, phi2=0.0, v_max=None)
    opt.setup(box(D, 0.0, 100.0, 1.0, 40), np.random.default_rng(0))
    X0 = opt.ask()
    opt.tell(X0, sphere(X0))
    V0 = opt._V.copy()
    assert np.all(np.abs(V0) <= 0.1)
    assert np.abs(V0).max() > 0.09
    X1 = opt.ask()
    np.testing.assert_allclose(X1, X0 + 2.0 * V0, rtol=0, atol=1e-12)
    # Attraction only (w -> 0 not possible, so subtract the inertia term): every coordinate
    # moves towards p_i and b by at most phi times the gap.
    opt = ParticleSwarm(v_max=None)
    opt.setup(box(D, 0.0, 100.0, 1.0, 40), np.random.default_rng(1))
    X0 = opt.ask()
    f0 = sphere(X0)
    opt.tell(X0, f0)
    V0 = opt._V.copy()
    X1 = opt.ask()
    step = X1 - X0 - 2.0 * V0  # phi1 r1 (p - x) + phi2 r2 (b - x), with p = x here
    gap = X0[np.argmin(f0)] - X0
    assert np.all(step * gap >= -1e-12)
    assert np.all(np.abs(step) <= 2.0 * np.abs(gap) + 1e-12)


def test_v_max_clamps_every_velocity_component():
    opt = ParticleSwarm(v_max=0.05, init_spread=1.0)
    space = box(D, 0.0, 100.0, 2.0, 300)
    run = minimise(opt, sphere, space, 0)
    asked = run.asked
    steps = np.diff(np.stack(asked[:-1]), axis=0)  # full generations: same particles
    assert np.abs(steps).max() <= 0.05 * 2.0 + 1e-12
    assert np.abs(steps).max() > 0.09


def test_coordinates_leaving_the_box_stop_on_the_bound_with_zero_velocity():
    space = SearchSpace(x0=np.full(5, 0.9), lower=-np.ones(5), upper=np.ones(5), radius=np.full(5, 2.0), budget=2000)
    opt = ParticleSwarm(**PAPER)
    opt.setup(space, np.random.default_rng(3))
    f = lambda X: np.sum((X - 2.0) ** 2, axis=1)  # noqa: E731
    on_bound = 0
    while not opt.stop():
        X = opt.ask()
        assert np.all(X >= space.lower)
        assert np.all(X <= space.upper)
        opt.tell(X, f(X))
        if opt.moves:
            at = np.isclose(X, 1.0, rtol=0, atol=1e-12) | np.isclose(X, -1.0, rtol=0, atol=1e-12)
            assert np.all(opt._V[: len(X)][at] == 0)
            on_bound += at.sum()
    assert on_bound > 0.3 * 5 * 2000
    assert opt.result.fbest == pytest.approx(5.0, abs=1e-9)
    np.testing.assert_allclose(opt.result.xbest, 1.0)


def test_truncated_generation_moves_only_its_particles():
    opt = ParticleSwarm()
    opt.setup(box(D, 0.0, 1.0, 1.0, 15), np.random.default_rng(0))
    X = opt.ask()
    opt.tell(X, sphere(X))
    Z, V = opt._Z.copy(), opt._V.copy()
    X1 = opt.ask()
    assert X1.shape == (5, D)
    opt.tell(X1, sphere(X1))
    np.testing.assert_array_equal(opt._Z[5:], Z[5:])
    np.testing.assert_array_equal(opt._V[5:], V[5:])
    assert not np.array_equal(opt._Z[:5], Z[:5])


@pytest.mark.parametrize(("budget", "last"), [(10, 10), (11, 1), (95, 5), (100, 10), (1500, 10)])
def test_budget_is_hit_exactly(budget, last):
    opt = ParticleSwarm()
    run = minimise(opt, lambda X: sphere(X, SHIFT), box(D, 0.0, 1.0, 1.0, budget), 1)
    asked = run.asked
    r = run.result
    assert sum(len(X) for X in asked) == r.evaluations == budget
    assert [len(X) for X in asked[:-1]] == [10] * (len(asked) - 1)
    assert len(asked[-1]) == last
    assert r.stop_reasons == {"budget": budget}
    assert opt.moves == len(asked) - 1 == len(opt.schedule)
    with pytest.raises(RuntimeError, match="budget"):
        opt.ask()


def test_budget_smaller_than_the_swarm_is_a_config_error():
    with pytest.raises(ConfigError, match="at least 10 evaluations"):
        ParticleSwarm().setup(box(D, 0.0, 1.0, 1.0, 9), np.random.default_rng(0))


@pytest.mark.parametrize(
    ("kw", "name"),
    [
        (dict(popsize=1), "popsize"),
        (dict(popsize=2.5), "popsize"),
        (dict(phi1=-1.0), "phi1"),
        (dict(phi2=float("inf")), "phi2"),
        (dict(w_max=0.0), "w_max"),
        (dict(w_min=0.0), "w_min"),
        (dict(w_min=2.5), "w_min"),
        (dict(w_max=0.5, w_min=0.6), "w_min"),
        (dict(v_max=0.0), "v_max"),
        (dict(v_max="fast"), "v_max"),
        (dict(init_spread=-1.0), "init_spread"),
        (dict(include_x0=1), "include_x0"),
    ],
)
def test_bad_parameters_are_config_errors(kw, name):
    with pytest.raises(ConfigError, match=rf"optimizer\.{name}\b"):
        ParticleSwarm(**kw)
