import pytest

from mmocap import config
from mmocap.errors import ConfigError
from mmocap.preflight import check_config


def test_the_shipped_config_and_every_experiment_pass():
    check_config(config.compose())
    for experiment in config.options("experiment"):
        check_config(config.compose([f"+experiment={experiment}"]))


@pytest.mark.parametrize(
    ("override", "key"),
    [
        ("tracking.evaluations=150.7", "tracking.evaluations"),
        ("tracking.evaluations=150.0", "tracking.evaluations"),  # an integer key takes integers only
        ("tracking.evaluations=1", "tracking.evaluations"),  # nothing left after the start pose
        ("body.dof=28", None),
        ("seed=4294967296", "seed"),
    ],
)
def test_values_are_checked_with_their_key(override, key):
    cfg = config.compose([override])
    if key is None:
        check_config(cfg)
    else:
        with pytest.raises(ConfigError, match=key):
            check_config(cfg)
