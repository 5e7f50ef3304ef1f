import math

import numpy as np
import pytest

from mmocap.api import Optimizer, SearchSpace
from mmocap.errors import ConfigError
from mmocap.optimizers.cmaes import BOUND_HANDLING, CMAES, BoxTransform, strategy_parameters
from mmocap.testing.objectives import box, ellipsoid, minimise, rosenbrock, sphere


def test_strategy_parameters_follow_table_2_for_39_dof():
    d = 39
    p = strategy_parameters(d)
    assert (p.lam, p.mu) == (14, 7)
    raw = [math.log(8) - math.log(i) for i in range(1, 8)]
    w = [r / sum(raw) for r in raw]
    np.testing.assert_allclose(p.weights, w, rtol=1e-12)
    assert p.weights.sum() == pytest.approx(1.0)
    assert np.all(np.diff(p.weights) < 0)
    mu_eff = 1 / sum(wi * wi for wi in w)
    assert p.mu_eff == pytest.approx(mu_eff, rel=1e-12)
    assert 4.0 < p.mu_eff < 5.0
    assert p.c_sigma == pytest.approx((mu_eff + 2) / (d + mu_eff + 3))
    assert p.d_sigma == pytest.approx(1 + p.c_sigma)  # sqrt((mu_eff-1)/(D+1)) - 1 < 0
    assert p.c_c == pytest.approx(4 / 43)
    assert p.mu_cov == pytest.approx(mu_eff)
    c_cov = 2 / (mu_eff * (d + math.sqrt(2)) ** 2) + (1 - 1 / mu_eff) * min(1, (2 * mu_eff - 1) / (41**2 + mu_eff))
    assert p.c_cov == pytest.approx(c_cov)

    opt = CMAES()
    opt.setup(box(d, 0.0, 1.0, 0.5, 100), np.random.default_rng(0))
    assert opt.params.lam == 14
    assert opt.ask().shape == (14, 39)
    assert strategy_parameters(28).lam == 13
    assert strategy_parameters(39, popsize=20).mu == 10


def test_satisfies_optimizer_protocol():
    assert isinstance(CMAES(), Optimizer)


def test_sphere_39d():
    r = minimise(CMAES(), sphere, box(39, 3.0, 10.0, 1.0, 20000), 0).result
    assert r.fbest < 1e-8
    assert r.evaluations <= 20000


def test_ellipsoid_10d_needs_covariance_adaptation():
    # Without covariance adaptation (isotropic ES with step-size control) f stays above 100
    # after 10 000 evaluations, and the best of 10 000 uniform samples in the box is ~1e5.
    r = minimise(CMAES(), ellipsoid, box(10, 3.0, 10.0, 1.0, 10000), 0).result
    assert r.fbest < 1e-6


def test_rosenbrock_10d_reaches_the_global_optimum_in_most_runs():
    # Random search in the box gets f ~ 1e3, an isotropic ES with a fixed step size f ~ 20.
    # With the default population CMA-ES ends in the local optimum near (-1, 1, ..., 1)
    # (f ~ 3.99) in roughly one run in five (Hansen's reported rate), so 10 seeds are run.
    results = [minimise(CMAES(), rosenbrock, box(10, 0.0, 5.0, 0.5, 30000), s).result for s in range(10)]
    solved = [r for r in results if r.fbest < 1e-10]
    assert len(solved) >= 7
    assert all(r.fbest < 4.0 for r in results)
    for r in solved:
        np.testing.assert_allclose(r.xbest, np.ones(10), atol=1e-4)


@pytest.mark.parametrize(("budget", "last"), [(100, 2), (95, 11), (98, 14), (14, 14), (15, 1)])
def test_budget_is_never_exceeded(budget, last):
    opt = CMAES()
    run = minimise(opt, sphere, box(39, 3.0, 10.0, 1.0, budget), 1)
    asked = run.asked
    r = run.result
    assert sum(len(X) for X in asked) == r.evaluations == budget
    assert [len(X) for X in asked[:-1]] == [14] * (len(asked) - 1)
    assert len(asked[-1]) == last
    assert r.iterations == len(asked)
    assert r.stop_reasons["budget"] == budget
    assert r.fbest == pytest.approx(min(sphere(X).min() for X in asked))
    with pytest.raises(RuntimeError, match="budget"):
        opt.ask()


@pytest.mark.parametrize("budget", [1, 13])
def test_budget_smaller_than_one_generation_is_a_config_error(budget):
    with pytest.raises(ConfigError, match=rf"at least 14 evaluations .*got {budget}"):
        CMAES().setup(box(39, 0.0, 1.0, 0.5, budget), np.random.default_rng(0))


@pytest.mark.parametrize("bounds", BOUND_HANDLING)
def test_asked_points_stay_in_bounds_and_optimum_on_bound_is_found(bounds):
    # The unconstrained optimum (2, ..., 2) lies outside the box.
    space = SearchSpace(x0=np.full(5, 0.9), lower=-np.ones(5), upper=np.ones(5), radius=np.full(5, 2.0), budget=3000)
    run = minimise(CMAES(bounds=bounds), lambda X: np.sum((X - 2.0) ** 2, axis=1), space, 3)
    X = np.concatenate(run.asked)
    assert np.all(X >= space.lower)
    assert np.all(X <= space.upper)
    assert run.result.fbest == pytest.approx(5.0, abs=1e-8)
    np.testing.assert_allclose(run.result.xbest, 1.0, atol=1e-8)
    # clipping puts many samples exactly on the bound; the transformation only approaches it
    assert (np.mean(X == space.upper) > 0.1) == (bounds == "clip")


def test_box_transform_maps_onto_the_box_smoothly_and_inverts():
    box_map = BoxTransform(np.array([-1.0, 0.0]), np.array([1.0, 3.0]))
    Y = np.linspace(-20, 20, 400001)[:, None] * np.ones(2)
    X = box_map(Y)
    np.testing.assert_array_equal(X.min(axis=0), [-1.0, 0.0])
    np.testing.assert_array_equal(X.max(axis=0), [1.0, 3.0])
    slope = np.abs(np.diff(X, axis=0) / np.diff(Y, axis=0))
    assert slope.max() <= 1 + 1e-6  # continuous, never steeper than the identity
    inside = np.array([[-0.2, 1.5], [0.7, 2.0]])
    np.testing.assert_array_equal(box_map(inside), inside)  # the identity inside the margins
    points = np.linspace([-1.0, 0.0], [1.0, 3.0], 101)
    np.testing.assert_allclose(box_map(box_map.inverse(points)), points, atol=1e-12)


def test_box_transform_maps_each_point_alike_whatever_else_is_in_the_call():
    """Calls with every point where the map is the identity take a shortcut; a point's image
    is the same in such a call and in one that takes the full map."""
    box_map = BoxTransform(np.array([-1.0, 0.0]), np.array([1.0, 3.0]))
    rng = np.random.default_rng(0)
    Y = rng.uniform([-0.9, 0.1], [0.9, 2.9], (1000, 2))
    Y = Y[np.all((Y >= box_map._identity[0]) & (Y <= box_map._identity[1]), axis=1)]
    edges = np.array([box_map._identity[0], box_map._identity[1]])  # the identity's own ends
    shortcut = box_map(np.r_[Y, edges])
    full = box_map(np.r_[Y, edges, [[5.0, -7.0]]])[:-1]  # a point outside: the full map
    np.testing.assert_array_equal(shortcut, full)
    np.testing.assert_array_equal(shortcut, np.r_[Y, edges])


def reference_box_map(box_map: BoxTransform, Y: np.ndarray) -> np.ndarray:
    """The map of the BoxTransform docstring on whole arrays: whole periods, reflection, margins."""
    start, end = box_map.lower - box_map.margin_lower, box_map.upper + box_map.margin_upper
    period = 2 * (end - start)
    Y = np.where((Y >= start) & (Y < start + period), Y, start + np.mod(Y - start, period))
    Y = np.where(Y > end, 2 * end - Y, Y)
    X = np.where(
        Y < box_map.lower + box_map.margin_lower, box_map.lower + (Y - start) ** 2 / (4 * box_map.margin_lower), Y
    )
    return np.where(
        Y > box_map.upper - box_map.margin_upper, box_map.upper - (Y - end) ** 2 / (4 * box_map.margin_upper), X
    )


def test_box_transform_is_the_whole_array_map_bit_for_bit():
    """Genotypes in the margins and beyond them (mapped one by one) get the values of the map
    computed on whole arrays, down to the last bit: at the margins' ends, the base period's
    end and many periods away, in calls that reach one side or both."""
    rng = np.random.default_rng(3)
    lower, upper = -rng.uniform(0.01, 2.0, 12), rng.uniform(0.01, 2.0, 12)
    lower[:2] = 0.0
    box_map = BoxTransform(lower, upper)
    start, end = lower - box_map.margin_lower, upper + box_map.margin_upper
    for spread in (0.01, 0.1, 1.0, 50.0):
        Y = rng.uniform(-0.01, 0.01, (14, 12))
        Y[:, :4] = lower[:4] + rng.normal(0.0, spread, (14, 4))
        Y[:, 4:6] = upper[4:6] + rng.normal(0.0, spread, (14, 2))
        Y[:4, 6:8] = [start[6:8], end[6:8], start[6:8] + 2 * (end - start)[6:8], np.nextafter(start[6:8], -1)]
        assert box_map(Y).tobytes() == reference_box_map(box_map, Y).tobytes()
        low_side = BoxTransform(lower[:4], upper[:4])  # a call that reaches the lower side only
        assert low_side(Y[:, :4]).tobytes() == reference_box_map(low_side, Y[:, :4]).tobytes()


def test_transform_needs_finite_bounds():
    space = SearchSpace(x0=np.zeros(3), lower=np.full(3, -np.inf), upper=np.ones(3), radius=np.ones(3), budget=100)
    with pytest.raises(ConfigError, match="finite search bounds; use optimizer.bounds=clip"):
        CMAES().setup(space, np.random.default_rng(0))
    CMAES(bounds="clip").setup(space, np.random.default_rng(0))


def _evaluations_to_target(opt, f, space, target, seed):
    opt.setup(space, np.random.default_rng(seed))
    while opt.result.fbest > target and not opt.stop():
        X = opt.ask()
        opt.tell(X, f(X))
    return opt.result.evaluations if opt.result.fbest <= target else math.inf


def test_optimum_on_the_bounds_within_a_small_factor_of_pycma():
    # A 10-D ellipsoid whose optimum lies on the upper bound in half the coordinates (like a
    # straight knee), started inside the box and with the start on the lower bound.
    cma = pytest.importorskip("cma")
    dim = 10
    centre = np.where(np.arange(dim) % 2 == 0, 2.0, 0.5)
    f_min = float(ellipsoid(np.clip(centre, -1, 1)[None] - centre, 1e3)[0])

    def f(X):
        return ellipsoid(X - centre, 1e3) - f_min

    for start in (0.0, -1.0):
        space = box(dim, start, 1.0, 1.0, 10**5)
        ours, clipped, reference = [], [], []
        for seed in range(3):
            ours.append(_evaluations_to_target(CMAES(sigma0=0.5), f, space, 1e-8, seed))
            clipped.append(_evaluations_to_target(CMAES(sigma0=0.5, bounds="clip"), f, space, 1e-8, seed))
            rng = np.random.default_rng(seed)
            es = cma.CMAEvolutionStrategy(
                np.full(dim, start),
                0.5,
                {
                    "bounds": [-1.0, 1.0],
                    "ftarget": 1e-8,
                    "maxfevals": 10**5,
                    "verbose": -9,
                    "seed": np.nan,
                    "randn": lambda *shape, rng=rng: rng.standard_normal(shape),
                },
            )
            es.optimize(lambda x: float(f(np.atleast_2d(x))[0]))
            assert es.result.fbest <= 1e-8
            reference.append(es.result.evaluations)
        # measured 1.3 (start 0) and 1.2 (start -1) against pycma; clipping 4x slower
        assert np.mean(ours) < 1.5 * np.mean(reference), f"{ours} vs pycma {reference}"
        assert np.mean(clipped) > 2 * np.mean(ours), f"clip {clipped} vs transform {ours}"


def test_stops_on_tolx_before_the_budget():
    r = minimise(CMAES(tolx=1e-6), sphere, box(10, 3.0, 10.0, 1.0, 20000), 2).result
    assert set(r.stop_reasons) == {"tolx"}
    assert r.stop_reasons["tolx"] < 1e-6
    assert r.evaluations < 20000


def test_stops_on_tolfun_on_a_flat_function():
    r = minimise(CMAES(), lambda X: np.ones(len(X)), box(10, 0.0, 1.0, 0.5, 20000), 2).result
    assert r.stop_reasons == {"tolfun": 0.0}
    assert r.evaluations < 20000


def test_same_seed_same_result_different_seed_different():
    space = box(10, 3.0, 10.0, 1.0, 500)
    a, b, c = (minimise(CMAES(), sphere, space, seed).result for seed in (7, 7, 8))
    np.testing.assert_array_equal(a.xbest, b.xbest)
    assert a.fbest == b.fbest
    assert not np.array_equal(a.xbest, c.xbest)


def test_setup_resets_state():
    opt = CMAES()
    space = box(10, 3.0, 10.0, 1.0, 300)
    first = minimise(opt, sphere, space, 4).result
    second = minimise(opt, sphere, space, 4).result
    np.testing.assert_array_equal(first.xbest, second.xbest)
    assert second.evaluations == 300


def test_tell_checks_its_input():
    opt = CMAES()
    opt.setup(box(5, 0.0, 1.0, 0.5, 100), np.random.default_rng(0))
    X = opt.ask()
    with pytest.raises(ValueError, match="exactly the .* array that ask"):
        opt.tell(X[:-1], sphere(X[:-1]))
    with pytest.raises(ValueError, match="exactly the .* array that ask"):
        opt.tell(X + 1e-3, sphere(X))
    with pytest.raises(ValueError, match="needs fitness of shape"):
        opt.tell(X, sphere(X)[:-1])
    with pytest.raises(ValueError, match="NaN fitness"):
        opt.tell(X, np.r_[sphere(X)[:-1], np.nan])
    opt.tell(X.tolist(), sphere(X))  # the same values in another container are the same candidates
    with pytest.raises(RuntimeError):
        opt.tell(X, sphere(X))


@pytest.mark.parametrize(
    ("kwargs", "name", "value"),
    [
        ({"sigma0": -1}, "optimizer.sigma0", "-1"),
        ({"sigma0": 0.0}, "optimizer.sigma0", "0.0"),
        ({"sigma0": float("nan")}, "optimizer.sigma0", "nan"),
        ({"popsize": 1}, "optimizer.popsize", "1"),
        ({"popsize": 4.5}, "optimizer.popsize", "4.5"),
        ({"tolx": -1e-3}, "optimizer.tolx", "-0.001"),
        ({"tolfun": -1}, "optimizer.tolfun", "-1"),
    ],
)
def test_bad_constructor_values_raise_config_error(kwargs, name, value):
    with pytest.raises(ConfigError, match=rf"{name}.*{value}"):
        CMAES(**kwargs)


def test_zero_budget_raises_config_error():
    with pytest.raises(ConfigError, match="budget.*0"):
        CMAES().setup(box(5, 0.0, 1.0, 0.5, 0), np.random.default_rng(0))


def test_sigma0_is_the_first_step_as_a_fraction_of_the_radius():
    space = SearchSpace(
        x0=np.zeros(6),
        lower=np.full(6, -100.0),
        upper=np.full(6, 100.0),
        radius=np.array([1, 1, 1, 10, 10, 10.0]),
        budget=10_000,
    )
    spreads = []
    for sigma0 in (1.0, 0.1):
        opt = CMAES(popsize=4000, sigma0=sigma0)
        opt.setup(space, np.random.default_rng(1))
        spreads.append(opt.ask().std(axis=0))
    np.testing.assert_allclose(spreads[0], [1, 1, 1, 10, 10, 10], rtol=0.06)
    np.testing.assert_allclose(spreads[1], [0.1, 0.1, 0.1, 1, 1, 1], rtol=0.06)


def test_ellipsoid_evaluations_within_a_small_factor_of_pycma():
    # pycma (Hansen's reference implementation, with its default active covariance update)
    # is installed with the example plugin. Same problem, start, step and target.
    cma = pytest.importorskip("cma")
    dim, target = 10, 1e-8
    ours, reference = [], []
    for seed in range(3):
        opt = CMAES(sigma0=1.0)
        opt.setup(box(dim, 3.0, 1e3, 1.0, 10**5), np.random.default_rng(seed))
        while opt.result.fbest > target:
            X = opt.ask()
            opt.tell(X, ellipsoid(X))
        ours.append(opt.result.evaluations)
        rng = np.random.default_rng(seed)
        es = cma.CMAEvolutionStrategy(
            np.full(dim, 3.0),
            1.0,
            {
                "ftarget": target,
                "verbose": -9,
                "seed": np.nan,
                "randn": lambda *shape, rng=rng: rng.standard_normal(shape),
            },
        )

        es.optimize(lambda x: float(ellipsoid(np.atleast_2d(x))[0]))
        reference.append(es.result.evaluations)
    ratio = np.mean(ours) / np.mean(reference)
    # measured 1.5 (1.1 against pycma without active CMA, the update Table 2 describes);
    # without covariance adaptation the ellipsoid takes ~100 times more evaluations
    assert ratio < 2.0, f"{ours} vs pycma {reference}"
